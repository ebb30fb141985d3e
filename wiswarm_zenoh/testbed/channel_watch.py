"""How a testbed run reads its channel while it runs: the tbf links' counters and rate
(``LinkWatch``), or the WiFi medium's (``MediumWatch``), sampled on a thread of their
own (``ChannelSampler``) so that reads, slow on a busy machine, never hold back the
supervision of the run's processes."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Protocol

from wiswarm_zenoh.testbed.channel import Channel
from wiswarm_zenoh.testbed.reassembly import Reassembly
from wiswarm_zenoh.testbed.spec import LinkCounters
from wiswarm_zenoh.testbed.wifi import WifiMedium
from wiswarm_zenoh.testbed.wifi_spec import window_counters
from wiswarm_zenoh.units import format_rate

log = logging.getLogger(__name__)

SAMPLE_PERIOD = 0.5  # seconds between readings of the channel


class _RateWatch:
    """Keeps the uplink's queue as sampled during a run, and its rate (noting any change)."""

    def __init__(self, channel: Channel, started: float, events: list[str]) -> None:
        self._channel = channel
        self._started = started
        self._events = events
        self._rates = (channel.spec.rate_bps, channel.spec.down_bps)
        self.backlog: list[int] = []

    def sample(self, uplink_backlog: int) -> None:
        self.backlog.append(uplink_backlog)
        current = Channel.attach(self._channel.run_id).spec
        rates = (current.rate_bps, current.down_bps)
        if rates != self._rates:
            self._events.append(
                f"t={time.time() - self._started:.1f}s: channel rate "
                f"{format_rate(self._rates[0])}/{format_rate(self._rates[1])} -> "
                f"{format_rate(rates[0])}/{format_rate(rates[1])} (up/down)")
            log.warning("%s", self._events[-1])
            self._rates = rates


class MediumWatch:
    """Samples the WiFi medium during a run: fails the run loudly (MediumFailed) once the
    simulation fell behind real time beyond its hard limit, and keeps its counters."""

    def __init__(self, medium: WifiMedium) -> None:
        self._medium = medium
        self.first = medium.stats()
        self.last = self.first

    def open(self) -> None:
        self.first = self._medium.stats()

    def sample(self) -> None:
        self._medium.check()
        self.last = self._medium.stats()

    def counters(self, span: float) -> dict[str, float]:
        return window_counters(self.first, self.last, span)


class LinkWatch:
    """The tbf channel's counters over the window, and its rate (noting changes). Rates
    are over the time between the two readings of the counters, not the window's: on a
    busy machine a reading comes late, and its bytes with it."""

    def __init__(self, channel: Channel, started: float, events: list[str]) -> None:
        self._channel = channel
        self._watch = _RateWatch(channel, started, events)
        self._first = self._read()
        self._last = self._first

    def _read(self) -> tuple[float, LinkCounters, float, LinkCounters]:
        """(when, uplink, when, downlink): each link's counters with the time its tc
        returned (tc reads them once started; starting it is what takes long on a busy
        machine, so the time before the call would be late by that)."""
        up = self._channel.uplink()
        up_at = time.monotonic()
        down = self._channel.downlink()
        return up_at, up, time.monotonic(), down

    def open(self) -> None:
        self._first = self._read()

    def sample(self) -> None:
        self._last = self._read()
        self._watch.sample(self._last[1].backlog_bytes)

    def counters(self, span: float) -> dict[str, float]:
        """``span`` aside (the medium's watch takes it): the readings say their own."""
        (up_t0, up0, down_t0, down0), (up_t1, up1, down_t1, down1) = self._first, self._last

        def mbps(before: int, after: int, t0: float, t1: float) -> float:
            return (after - before) * 8 / 1e6 / (t1 - t0) if t1 > t0 else 0.0

        backlog = self._watch.backlog
        return {
            "uplink_mbps": mbps(up0.sent_bytes, up1.sent_bytes, up_t0, up_t1),
            "downlink_mbps": mbps(down0.sent_bytes, down1.sent_bytes, down_t0, down_t1),
            "uplink_drops": float(up1.dropped - up0.dropped),
            "downlink_drops": float(down1.dropped - down0.dropped),
            "uplink_backlog_kb": sum(backlog) / len(backlog) / 1e3 if backlog else 0.0,
        }


class ChannelWatch(Protocol):
    """What a run reads its channel with: the window's first reading, then samples."""

    def open(self) -> None: ...

    def sample(self) -> None: ...


class ChannelSampler:
    """Reads the channel (``watch``) on a thread of its own: the window's first counters
    at ``t0``, then a sample every SAMPLE_PERIOD until stopped. Each read is a tc or
    ns-3 call, seconds long on a busy machine: on the supervising loop, they delayed the
    restart of a process that died. What the thread raises (MediumFailed: the medium fell
    behind real time) is raised again by ``check``, on the supervising loop."""

    def __init__(self, watch: ChannelWatch, read_reassembly: Callable[[], Reassembly],
                 t0: float) -> None:
        self.watch = watch
        self.reasm0: Reassembly | None = None  # the leader side's, as the window opened
        self._read_reassembly = read_reassembly
        self._t0 = t0
        self._error: Exception | None = None
        self._stopped = threading.Event()
        self._thread = threading.Thread(target=self._sample, name="testbed sampler",
                                        daemon=True)
        self._thread.start()

    def _sample(self) -> None:
        try:
            if self._stopped.wait(max(0.0, self._t0 - time.time())):
                return
            self.watch.open()
            self.reasm0 = self._read_reassembly()
            while not self._stopped.wait(SAMPLE_PERIOD):
                self.watch.sample()
        except Exception as exc:  # raised again where the run is supervised
            self._error = exc

    def check(self) -> None:
        if self._error is not None:
            raise self._error

    def stop(self) -> None:
        """Stop sampling; a read under way ends first."""
        self._stopped.set()
        self._thread.join()
