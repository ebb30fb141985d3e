"""A process ends as the interpreter would, short of its finalisation: threads joined,
exit handlers run, output flushed, its code kept."""

from __future__ import annotations

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import atexit, sys, threading
    from wiswarm_zenoh.programs.process_exit import exit_without_finalizing

    go = threading.Event()
    def worker():
        go.wait()
        print("worker done", flush=True)
    threading.Thread(target=worker).start()
    atexit.register(lambda: print("exit handler", file=sys.stderr))
    sys.stdout.write("unflushed line ")
    go.set()
    exit_without_finalizing(3)
    print("never")
""")


def test_an_exit_without_finalizing_keeps_what_an_exit_does() -> None:
    done = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 3, done.stderr
    assert "unflushed line" in done.stdout and "never" not in done.stdout
    assert "worker done" in done.stdout
    assert "exit handler" in done.stderr
