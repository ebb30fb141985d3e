"""How a process that held Zenoh sessions ends: as the interpreter would, short of its
finalisation.

Closing a session does not wait for every callback Zenoh runs on its own threads (a
direct callback's last call, or the drop of a Python callable it held, needs the GIL).
Before Python 3.14, a thread that asks for the GIL while the interpreter finalises is
ended with ``pthread_exit``; unwinding through Zenoh's Rust frames then aborts the
process ("FATAL: exception not rethrown", exit code -6) after a run that went well, and
a service manager or a testbed run reports a crash. It was seen about once in 30 loaded
test suites, on an edge leader polled until its last moment.

So the ``wiswarm`` script and every ``spawn`` child end here once their sessions are
closed: non-daemon threads joined and exit handlers run (``logging`` flushes,
``multiprocessing`` reaps children), standard streams flushed, then ``os._exit``, so
that nothing can call into a finalising interpreter.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import sys
import threading
from typing import NoReturn


def exit_without_finalizing(code: int) -> NoReturn:
    """End the process with ``code`` after what an interpreter's exit does first."""
    for thread in threading.enumerate():
        if thread is not threading.current_thread() and not thread.daemon:
            thread.join()
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):  # a closed pipe: nothing left to tell
            stream.flush()
    os._exit(code)
