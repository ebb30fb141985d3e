"""Progress of a long run on stderr, for commands that run many experiments."""

from __future__ import annotations

import sys
import time


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
