"""Progress of a long run on stderr, and what it wrote at the end, for commands that
run many experiments."""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from pathlib import Path


class ProgressBar:
    """``[#####-----] done/total  elapsed`` on stderr, redrawn in place."""

    def __init__(self, label: str, width: int = 30) -> None:
        self.label = label
        self.width = width
        self.started = time.monotonic()

    def __call__(self, done: int, total: int) -> None:
        filled = self.width * done // max(total, 1)
        elapsed = time.monotonic() - self.started
        bar = "#" * filled + "-" * (self.width - filled)
        end = "\n" if done >= total else ""
        print(f"\r{self.label} [{bar}] {done}/{total} runs {elapsed:6.0f} s", end=end,
              file=sys.stderr, flush=True)


def show_written(paths: Sequence[Path], interrupted: bool) -> int:
    """Print every file a study wrote, then its markdown table (the last file, if it is
    one); return the exit code: 130 when the run was cut short (Ctrl-C), else 0."""
    for path in paths:
        print(path)
    if paths and paths[-1].suffix == ".md":
        print(paths[-1].read_text(), end="")
    return 130 if interrupted else 0
