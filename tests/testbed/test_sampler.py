"""The run's channel reads on a thread of their own: a slow read never holds back the
supervision of the processes, the window opens at its time, and a failure the reads
meet (the WiFi medium fell behind real time) is raised where the run is supervised."""

from __future__ import annotations

import threading
import time

import pytest

from wiswarm_zenoh.testbed.channel_watch import ChannelSampler
from wiswarm_zenoh.testbed.reassembly import Reassembly
from wiswarm_zenoh.testbed.wifi_spec import MediumFailed

WAIT = 30.0
CLEAN = Reassembly(requests=0, oks=0, fails=0, held=0, held_bytes=0)


class SlowWatch:
    """A channel whose reads wait for ``go``; counts them."""

    def __init__(self, fail_on: int | None = None) -> None:
        self.go = threading.Event()
        self.entered = threading.Event()
        self.opened_at: float | None = None
        self.samples = 0
        self.sampled = threading.Condition()
        self._fail_on = fail_on

    def open(self) -> None:
        self.opened_at = time.time()

    def sample(self) -> None:
        self.entered.set()
        self.go.wait()
        with self.sampled:
            self.samples += 1
            self.sampled.notify_all()
        if self.samples == self._fail_on:
            raise MediumFailed("the simulation fell 120 ms behind real time")


def test_a_slow_read_holds_back_nothing_and_the_window_opens_at_its_time() -> None:
    watch = SlowWatch()
    t0 = time.time() + 0.2
    sampler = ChannelSampler(watch, lambda: CLEAN, t0)
    try:
        assert watch.entered.wait(WAIT)  # its first sample is under way, blocked for good
        sampler.check()  # what the supervising loop calls: it returns all the same
        assert watch.opened_at is not None and watch.opened_at >= t0
        assert sampler.reasm0 is CLEAN
        watch.go.set()
        with watch.sampled:
            assert watch.sampled.wait_for(lambda: watch.samples >= 2, WAIT)
    finally:
        watch.go.set()
        sampler.stop()
    sampler.check()


def test_a_medium_failure_met_by_a_read_is_raised_by_check() -> None:
    watch = SlowWatch(fail_on=2)
    watch.go.set()
    sampler = ChannelSampler(watch, lambda: CLEAN, time.time())
    with watch.sampled:
        assert watch.sampled.wait_for(lambda: watch.samples >= 2, WAIT)
    sampler.stop()
    with pytest.raises(MediumFailed, match="behind real time"):
        sampler.check()


def test_a_run_stopped_before_its_window_never_opens_it() -> None:
    watch = SlowWatch()
    sampler = ChannelSampler(watch, lambda: CLEAN, time.time() + 3600)
    sampler.stop()
    sampler.check()
    assert watch.opened_at is None and sampler.reasm0 is None
