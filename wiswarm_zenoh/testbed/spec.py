"""What a channel is and what it reports, and whether one can be built here: the plain
values the channel, the studies and the command line share, with no ``ip``/``tc``."""

from __future__ import annotations

import math
import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass

from wiswarm_zenoh.units import MAX_RATE_BPS, MIN_RATE_BPS, format_rate

MTU = 1500
MAX_FRAME_BYTES = MTU + 14  # what tbf sees of a full-size packet: the Ethernet header too
_U32 = 2**32 - 1
_TICK_S = 64e-9  # tbf keeps its bucket as a u32 count of 64 ns ticks
SIM_HINT = "use `wiswarm sim link`, the simulator's model of the same link"


class TestbedUnavailable(Exception):
    """Namespaces and qdiscs cannot be built here (not root, or ``ip``/``tc`` missing)."""

    __test__ = False  # not a pytest test class, despite its name


def unavailable_reason(euid: int, which: Callable[[str], str | None]) -> str | None:
    """Why the testbed cannot run for this user and these tools, or None if it can."""
    if euid != 0:
        return ("the emulated channel needs root (it builds network namespaces and tc "
                f"qdiscs): run it as root, or {SIM_HINT}")
    missing = [f"`{tool}`" for tool in ("ip", "tc") if which(tool) is None]
    if missing:
        return (f"{' and '.join(missing)} not found: the emulated channel needs iproute2 "
                f"(ip, tc); install it, or {SIM_HINT}")
    return None


def check_available() -> None:
    """Raise TestbedUnavailable, saying which requirement is missing."""
    reason = unavailable_reason(os.geteuid(), shutil.which)
    if reason is not None:
        raise TestbedUnavailable(reason)


@dataclass(frozen=True)
class ChannelSpec:
    """Rates (bits/s) of both directions, the tbf queue limit (seconds) and burst."""

    rate_bps: int = 20_000_000
    queue_s: float = 0.2
    down_rate_bps: int | None = None
    burst_bytes: int = 32 * 1024

    def __post_init__(self) -> None:
        for name in ("rate_bps", "down_rate_bps"):
            value = getattr(self, name)
            if value is None and name == "down_rate_bps":
                continue
            if not (isinstance(value, int) and not isinstance(value, bool)
                    and MIN_RATE_BPS <= value <= MAX_RATE_BPS):
                raise ValueError(f"{name} must be a whole number of bits/s between "
                                 f"{format_rate(MIN_RATE_BPS)} and "
                                 f"{format_rate(MAX_RATE_BPS)}, got {value!r}")
        slowest, fastest = sorted((self.rate_bps, self.down_bps))
        if not (isinstance(self.queue_s, int | float) and math.isfinite(self.queue_s)
                and self.queue_s > 0):
            raise ValueError(f"queue_s must be > 0 seconds, got {self.queue_s!r}")
        # tc rounds the bucket to whole microseconds at the rate: keep a full frame in it,
        # or tbf drops every full-size packet.
        least = MAX_FRAME_BYTES + math.ceil(fastest / 8e6) + 1
        if not (isinstance(self.burst_bytes, int) and self.burst_bytes >= least):
            raise ValueError(f"burst_bytes must be a whole number >= {least} (one {MTU}-byte "
                             f"MTU packet at {format_rate(fastest)}), got {self.burst_bytes!r}")
        if self.burst_bytes * 8 / slowest > _U32 * _TICK_S:
            raise ValueError(f"burst_bytes {self.burst_bytes} lasts more than "
                             f"{_U32 * _TICK_S:.0f} s at {format_rate(slowest)}, tbf's limit")
        if fastest / 8 * self.queue_s + self.burst_bytes > _U32:
            raise ValueError(f"queue_s {self.queue_s:g} s at {format_rate(fastest)} would "
                             "hold more than 4 GB, tbf's limit")

    @property
    def down_bps(self) -> int:
        """The leader -> followers rate (the uplink's unless set)."""
        return self.rate_bps if self.down_rate_bps is None else self.down_rate_bps

    def limit_bytes(self, rate_bps: int) -> int:
        """tbf's queue limit in one direction of that rate: ``rate * latency + burst``."""
        return int(rate_bps / 8 * self.queue_s + self.burst_bytes)


DEFAULT_SPEC = ChannelSpec()


@dataclass(frozen=True)
class LinkCounters:
    """One direction's tbf statistics (``tc -s qdisc``), cumulative since the build."""

    sent_bytes: int
    sent_packets: int
    dropped: int
    overlimits: int
    backlog_bytes: int
