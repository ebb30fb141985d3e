"""The commands a channel is built, read and removed with, as ``tc.run`` runs them."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from wiswarm_zenoh.testbed import tc

# Killed by SIGINT on its first run (as a Ctrl-C meant for the study reaches a command
# between its fork and its own session), done on its second.
ONCE_INTERRUPTED = """
import os, signal, sys
mark = sys.argv[1]
if not os.path.exists(mark):
    open(mark, "w").close()
    os.kill(os.getpid(), signal.SIGINT)
print("done")
"""


def test_a_command_a_ctrl_c_reached_runs_again(tmp_path: Path) -> None:
    mark = tmp_path / "interrupted-once"
    assert tc.run(sys.executable, "-c", ONCE_INTERRUPTED, str(mark)) == "done\n"
    assert mark.exists()


def test_a_command_that_fails_says_how(tmp_path: Path) -> None:
    with pytest.raises(RuntimeError, match=r"failed \(exit 3\): no good"):
        tc.run(sys.executable, "-c", "import sys; sys.stderr.write('no good'); sys.exit(3)")
