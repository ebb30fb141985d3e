"""The progress bar and log lines on one stream: a record written while the bar is
drawn comes out on a line of its own, and the bar is drawn again after it."""

from __future__ import annotations

import io
import logging
from collections.abc import Iterator

import pytest

from wiswarm_zenoh.options import ProgressBar


class Terminal(io.StringIO):
    """A captured stream that says it is a terminal, and what a terminal would show."""

    def isatty(self) -> bool:
        return True

    def screen(self) -> list[str]:
        lines, line, col = [], "", 0
        text = self.getvalue()
        i = 0
        while i < len(text):
            if text.startswith("\x1b[K", i):
                line, i = line[:col], i + 3
                continue
            char = text[i]
            if char == "\n":
                lines.append(line)
                line, col = "", 0
            elif char == "\r":
                col = 0
            else:
                line = line[:col] + char + line[col + 1:]
                col += 1
            i += 1
        return [*lines, line] if line else lines


@pytest.fixture
def handler_on() -> Iterator[list[logging.Handler]]:
    """Root log handlers added by a test, removed after it."""
    added: list[logging.Handler] = []
    yield added
    for handler in added:
        logging.getLogger().removeHandler(handler)


def _log_to(stream: io.StringIO, added: list[logging.Handler]) -> logging.Logger:
    handler = logging.StreamHandler(stream)
    handler.setFormatter(logging.Formatter("%(levelname)s %(message)s"))
    logging.getLogger().addHandler(handler)
    added.append(handler)
    log = logging.getLogger("tests.progress")
    log.setLevel(logging.INFO)
    return log


def test_a_log_line_during_a_bar_on_a_terminal_gets_its_own_line(
        handler_on: list[logging.Handler]) -> None:
    terminal = Terminal()
    log = _log_to(terminal, handler_on)
    bar = ProgressBar("study", width=4, stream=terminal)
    bar(1, 4)
    log.warning("follower uav3 left")
    assert terminal.screen() == ["WARNING follower uav3 left",
                                 "study [#---] 1/4 runs      0 s"]
    bar(2, 4)
    log.info("a second line")
    bar(4, 4)
    assert terminal.screen() == ["WARNING follower uav3 left", "INFO a second line",
                                 "study [####] 4/4 runs      0 s"]
    log.info("after the bar")  # nothing left to clear or draw again
    assert terminal.screen()[-1] == "INFO after the bar"


def test_off_a_terminal_every_update_and_every_record_is_a_line(
        handler_on: list[logging.Handler]) -> None:
    stream = io.StringIO()
    log = _log_to(stream, handler_on)
    bar = ProgressBar("study", width=4, stream=stream)
    bar(1, 2)
    log.warning("something to act on")
    bar(2, 2)
    assert stream.getvalue().splitlines() == [
        "study [##--] 1/2 runs      0 s", "WARNING something to act on",
        "study [####] 2/2 runs      0 s"]
