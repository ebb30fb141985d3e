"""A follower that misses a few dozen polls and answers at once is INFO; one still silent
after the grace is the WARNING, unless it left meanwhile."""

from __future__ import annotations

import logging
import threading
from collections.abc import Iterator

import pytest

from wiswarm_zenoh.transport.silence import SilenceLog, log

GRACE = 0.05


class Lines(logging.Handler):
    """Every record of the leader's logger, waitable."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []
        self.came = threading.Event()

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)
        self.came.set()

    def at(self, level: int) -> list[str]:
        return [r.getMessage() for r in self.records if r.levelno == level]


@pytest.fixture
def lines() -> Iterator[Lines]:
    handler = Lines()
    log.addHandler(handler)
    level = log.level
    log.setLevel(logging.DEBUG)
    yield handler
    log.removeHandler(handler)
    log.setLevel(level)


def test_a_short_silence_is_info_and_never_warned_of(lines: Lines) -> None:
    asked = threading.Event()

    def relevant(follower: str) -> bool:
        asked.set()
        return True

    silence = SilenceLog(relevant, GRACE)
    silence.silent("uav1", 20)
    silence.answering("uav1", 0.03)
    assert lines.at(logging.INFO) == ["follower uav1 missed 20 polls and answers again, "
                                      "after 0.03 s"]
    assert not asked.wait(GRACE * 4)  # the warning's timer was cancelled: never asked
    assert not lines.at(logging.WARNING)


def test_a_lasting_silence_is_warned_of_once_and_its_end_said(lines: Lines) -> None:
    silence = SilenceLog(lambda follower: True, GRACE)
    silence.silent("uav1", 20)
    assert lines.came.wait(5.0)
    [warning] = lines.at(logging.WARNING)
    assert warning.startswith("follower uav1 stopped answering (its last 20 polls")
    silence.answering("uav1", 1.5)
    assert lines.at(logging.INFO) == ["follower uav1 answers again, after 1.5 s"]


def test_a_follower_that_left_is_not_warned_of(lines: Lines) -> None:
    asked = threading.Event()

    def relevant(follower: str) -> bool:
        asked.set()
        return False  # it left meanwhile

    SilenceLog(relevant, GRACE).silent("uav1", 20)
    assert asked.wait(5.0)
    assert not lines.records


def test_a_follower_that_rejoined_is_not_warned_of(lines: Lines) -> None:
    """Its join forgot the polls it missed (it is no longer silent) without an answer,
    so no "answers again" comes to cancel the warning: the join does (a cloud leader
    warned of a site's followers after their router restarted, while they answered)."""
    asked = threading.Event()

    def relevant(follower: str) -> bool:
        asked.set()
        return True  # a member again

    silence = SilenceLog(relevant, GRACE)
    silence.silent("uav1", 20)
    silence.rejoined("uav1")
    assert not asked.wait(GRACE * 4)  # the warning's timer was cancelled: never asked
    assert not lines.records
