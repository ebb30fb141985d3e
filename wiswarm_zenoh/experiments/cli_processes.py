"""``wiswarm`` commands run as a user runs them, in a testbed namespace: the followers of
the ROS 2 benchmarks are started from the command line they document, not as children
of the experiment's own code."""

from __future__ import annotations

import logging
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

log = logging.getLogger(__name__)

STOP_TIMEOUT = 5.0
Cli = tuple[str, subprocess.Popen[bytes]]  # what it runs, the process


def start_cli(ns: str, argv: list[str], logs: Path, tag: str) -> Cli:
    """``wiswarm <argv>`` in namespace ``ns`` (``ip netns exec``), its stderr appended to
    ``logs/<tag>.log``."""
    with (logs / f"{tag}.log").open("ab") as err:
        return (" ".join(["wiswarm", *argv]), subprocess.Popen(
            ["ip", "netns", "exec", ns, sys.executable, "-m", "wiswarm_zenoh.cli.main", *argv],
            stdout=subprocess.DEVNULL, stderr=err, start_new_session=True))


def stop_cli(clis: Sequence[Cli]) -> None:
    """SIGTERM to each, then killed if it does not end within STOP_TIMEOUT."""
    for _, proc in clis:
        proc.terminate()
    for what, proc in clis:
        try:
            proc.wait(STOP_TIMEOUT)
        except subprocess.TimeoutExpired:
            log.warning("%s did not stop: killing it", what)
            proc.kill()
            proc.wait()
