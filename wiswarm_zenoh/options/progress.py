"""Progress of a long run on stderr, and what it wrote at the end, for commands that
run many experiments.

A bar redrawn in place and log lines share one stream: a record written while the bar
is on screen would be spliced into it. So the bar takes over the stream of every root
log handler that writes where it draws (``StreamHandler.setStream``), and every write
there goes through one lock: the bar's line is cleared first and drawn again after a
line that ended. Where the stream is no terminal (a file, a pipe) nothing is redrawn:
each update is a line of its own."""

from __future__ import annotations

import logging
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

CLEAR_LINE = "\r\x1b[K"  # to the line's start, and erase it


class _BarStream:
    """A log handler's stream while a bar is drawn on it: writes clear the bar's line
    and draw the bar again once a line is complete."""

    def __init__(self, stream: TextIO, bar: ProgressBar) -> None:
        self.stream = stream
        self.bar = bar

    def write(self, text: str) -> int:
        with self.bar.lock:
            drawn = self.bar.drawn
            if drawn:
                self.stream.write(CLEAR_LINE)
            written = self.stream.write(text)
            if drawn and text.endswith("\n"):
                self.stream.write(drawn)
            self.stream.flush()
            return written

    def flush(self) -> None:
        self.stream.flush()


class ProgressBar:
    """``[#####-----] done/total  elapsed`` on ``stream`` (stderr), redrawn in place on a
    terminal; log records to the same stream come out on lines of their own."""

    def __init__(self, label: str, width: int = 30, stream: TextIO | None = None) -> None:
        self.label = label
        self.width = width
        self.started = time.monotonic()
        self.stream = sys.stderr if stream is None else stream
        self.lock = threading.RLock()
        self.drawn = ""  # what a log line must draw again after it ("" : nothing on screen)
        self._tty = self.stream.isatty()
        for handler in logging.getLogger().handlers:
            if isinstance(handler, logging.StreamHandler):
                target = handler.stream
                if isinstance(target, _BarStream):  # a bar before this one
                    target = target.stream
                if target is self.stream:
                    handler.setStream(_BarStream(self.stream, self))

    def __call__(self, done: int, total: int) -> None:
        filled = self.width * done // max(total, 1)
        elapsed = time.monotonic() - self.started
        bar = "#" * filled + "-" * (self.width - filled)
        text = f"{self.label} [{bar}] {done}/{total} runs {elapsed:6.0f} s"
        with self.lock:
            if not self._tty:
                self.stream.write(text + "\n")
            elif done >= total:
                self.stream.write(CLEAR_LINE + text + "\n")
                self.drawn = ""
            else:
                # The cursor goes back to the line's start: a line another process
                # writes (a child's log) then covers the bar instead of following it.
                self.drawn = text + "\r"
                self.stream.write(CLEAR_LINE + self.drawn)
            self.stream.flush()


def show_written(paths: Sequence[Path], interrupted: bool) -> int:
    """Print every file a study wrote, then its markdown table (the last file, if it is
    one); return the exit code: 130 when the run was cut short (Ctrl-C), else 0."""
    for path in paths:
        print(path)
    if paths and paths[-1].suffix == ".md":
        print(paths[-1].read_text(), end="")
    return 130 if interrupted else 0
