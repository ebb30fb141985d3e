"""Zenoh's own log in a Python process: link loss, reconnection and access-control denials.

Zenoh (1.10) writes its log to stdout, and only once ``zenoh.init_log_from_env_or`` is
called; ``RUST_LOG`` overrides the level chosen here. Access control logs its decisions
only at trace level, one line per message allowed as well as refused: a router that must
show refusals at its default level therefore turns that target to trace and passes its
stdout through ``acl_log.DenialFilter`` (a pipe in front of fd 1, read by a thread).
"""

from __future__ import annotations

import atexit
import os
import threading

import zenoh

from wiswarm_zenoh.programs.acl_log import DenialFilter

LOG_FORMAT = "%(asctime)s %(levelname)s %(name)s: %(message)s"  # ours, every process
ACCESS_CONTROL = "zenoh::net::routing::interceptor::access_control"
# Zenoh's warnings that are expected consequences of this design, hidden at the default
# level (``-v`` or ``RUST_LOG`` shows them): a reply or final that comes after its get
# was closed (a poll the leader gave up; it counts such replies itself), undeclarations
# of tokens and subscribers whose session went first (a node stopping, a standby taking
# over), the scouting delay of a client whose router is not up yet (the node says
# itself when no router is reached), and the admin space's bookkeeping of a link event
# whose transport is already gone or not yet there (peers opening and closing links).
EXPECTED = ("zenoh::net::routing::dispatcher::queries=error,zenoh::api::session=error,"
            "zenoh::net::routing::dispatcher::token=error,"
            "zenoh::net::routing::dispatcher::pubsub=error,"
            "zenoh::net::runtime::orchestrator=error,zenoh::api::admin=error")
LEVELS = (f"warn,{EXPECTED}", "info", "debug")  # by -v count


def directive(verbosity: int, denials: bool) -> str:
    """Zenoh's log filter for ``-v`` given ``verbosity`` times; with ``denials``, access
    control's decisions too (``-v`` and more: allowed ones as well)."""
    level = LEVELS[min(verbosity, len(LEVELS) - 1)]
    return f"{level},{ACCESS_CONTROL}=trace" if denials or verbosity else level


def init_zenoh_log(verbosity: int = 0, denials: bool = False) -> None:
    """Show Zenoh's log (once per process; later calls change nothing). With ``denials``
    and no ``-v``, access control shows what it refused, not what it allowed."""
    if not os.isatty(1):
        os.environ.setdefault("NO_COLOR", "1")  # no colour codes in a file or a pipe
    if denials and verbosity == 0 and "RUST_LOG" not in os.environ:
        _filter_stdout(DenialFilter())
    zenoh.init_log_from_env_or(directive(verbosity, denials))


def _filter_stdout(denials: DenialFilter) -> None:
    """Route fd 1 through a pipe; a thread passes on what ``denials`` shows."""
    read_end, write_end = os.pipe()
    real_stdout = os.dup(1)
    os.dup2(write_end, 1)
    os.close(write_end)

    def pump() -> None:
        with os.fdopen(read_end, "rb") as lines, os.fdopen(real_stdout, "wb", 0) as out:
            for line in lines:
                shown = denials.feed(line)
                if shown is not None:
                    out.write(shown)

    thread = threading.Thread(target=pump, name="zenoh-log", daemon=True)
    thread.start()

    def drain() -> None:
        """At exit: no more writers, so the thread passes on what is left, then ends."""
        saved = os.dup(real_stdout)
        os.dup2(saved, 1)
        os.close(saved)
        thread.join(timeout=2.0)

    atexit.register(drain)
