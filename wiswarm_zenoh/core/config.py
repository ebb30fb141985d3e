"""Validated settings of the follower and the leader."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

QueueKind = Literal["lifo", "fifo"]
InFlight = int | Literal["auto"]  # polls out at once, or "auto": the leader finds it
DropRule = Literal["tail", "head"]

# Bytes of a fragment that are not payload (msgpack map of the reply); a fragment size
# at or below this could never carry data.
FRAGMENT_HEADER_BYTES = 320
DEFAULT_MAX_UPDATE_BYTES = 16 * 1024 * 1024
DEFAULT_MAX_FRAGMENTS = 4096


def _require(ok: bool, field: str, allowed: str, value: object) -> None:
    if not ok:
        raise ValueError(f"{field} must be {allowed}, got {value!r}")


@dataclass(frozen=True)
class FollowerConfig:
    """How a follower queues and fragments its updates (paper, Section II-B).

    ``abandon_after``: a half-sent update is dropped for a fresher waiting one when none
    of its fragments has been acknowledged yet, or when the waiting one is newer by more
    than this many seconds. ``control_window``: how far (seconds) a control message's
    leader time may be from that leader's clock (see ``control_gate``).
    ``poller_expiry``: after this many seconds without a poll, a leader no longer keeps
    the queue from a poller of a lower epoch (see ``pollers``).
    """

    queue: QueueKind = "lifo"
    capacity: int = 1
    drop: DropRule = "tail"
    rate_hz: float | None = None
    fragment_size: int = 65536
    max_update_bytes: int = DEFAULT_MAX_UPDATE_BYTES
    abandon_after: float = 1.0
    control_window: float = 1.0
    poller_expiry: float = 2.0

    def __post_init__(self) -> None:
        _require(self.queue in ("lifo", "fifo"), "queue", "'lifo' or 'fifo'", self.queue)
        _require(self.capacity >= 1, "capacity", "an integer >= 1", self.capacity)
        _require(self.drop in ("tail", "head"), "drop", "'tail' or 'head'", self.drop)
        _require(
            self.rate_hz is None or (math.isfinite(self.rate_hz) and self.rate_hz > 0),
            "rate_hz", "None or a finite number > 0", self.rate_hz,
        )
        _require(
            self.fragment_size > FRAGMENT_HEADER_BYTES,
            "fragment_size", f"> {FRAGMENT_HEADER_BYTES} bytes (the fragment header)",
            self.fragment_size,
        )
        _require(self.max_update_bytes >= 1, "max_update_bytes", ">= 1", self.max_update_bytes)
        _require(
            self.abandon_after >= 0 and not math.isnan(self.abandon_after),
            "abandon_after", ">= 0 seconds", self.abandon_after,
        )
        for name in ("control_window", "poller_expiry"):
            value = getattr(self, name)
            _require(math.isfinite(value) and value > 0, name, "> 0 seconds", value)


@dataclass(frozen=True)
class LeaderConfig:
    """How the leader schedules polls and estimates its followers (paper, Section II-D).

    ``prior_p`` stands in for the polls not yet made while fewer than ``window`` polls
    were sent to a follower. A follower none of whose last ``window`` polls was answered
    (p_hat = 0: dead, hung, or only garbage) leaves the policy's schedule and is probed
    alone, first after ``probe_interval`` seconds, then at doubling intervals up to
    ``probe_max``: it costs at most one timeout per probe and cannot starve the others,
    and it rejoins the schedule as soon as a probe is answered. ``weight_floor`` keeps a
    follower whose urgency fell to zero in the schedule (a stopped car must still be
    seen to start).

    ``timeout`` is the longest wait for a reply; with ``adaptive_timeout`` each follower
    gets its own, from its answered polls, at least ``timeout_floor`` (see
    ``poll_timing``). ``price_by_time``: the policy's index is taken per unit of a poll's
    expected time, so that a follower whose polls time out costs what they really cost.

    ``in_flight``: polls out at once, each to a different follower. 1 is the paper's rule
    and the only right one where the polls share a radio channel. A leader whose polls
    cross a link that is not shared (a cloud leader polling edge leaders over a WAN,
    which answer from what they hold) keeps the link busy with a few: about
    (round trip + one update's time on the link) / that time. ``"auto"``: the leader
    finds that number from its throughput and keeps adjusting it (``in_flight``); on
    a shared channel it stays at 1.

    ``pace_sources``: the index takes the age a poll can remove, from each source's
    pace as its updates show it (``sources``): a follower whose source is slower than
    the polls is polled when it is due, and no poll goes out while none is. False:
    every source is taken as always fresh (the paper's index exactly).

    ``control_period``: the control information goes with the first poll after it
    changes (new control, a follower joining, a new epoch) and is repeated with a poll
    at least this often (seconds); 0 sends it with every poll, as the paper does.
    Simulator and Zenoh shell send it as the core says, so they send the same.
    """

    policy: str = "whittle"
    timeout: float = 0.3
    window: int = 20
    prior_p: float = 1.0
    probe_interval: float = 0.5
    probe_max: float = 8.0
    alpha: float = 0.8
    initial_weight: float = 1.0
    weight_floor: float = 0.1
    max_fragments: int = DEFAULT_MAX_FRAGMENTS
    max_update_bytes: int = DEFAULT_MAX_UPDATE_BYTES
    clock_samples: int = 8
    adaptive_timeout: bool = True
    timeout_floor: float = 0.01
    price_by_time: bool = True
    in_flight: InFlight = 1
    pace_sources: bool = True
    control_period: float = 0.1

    def __post_init__(self) -> None:
        from wiswarm_zenoh.core.policies import POLICIES

        _require(self.policy in POLICIES, "policy", f"one of {sorted(POLICIES)}", self.policy)
        _require(
            math.isfinite(self.timeout) and self.timeout > 0, "timeout", "> 0 seconds",
            self.timeout,
        )
        _require(self.window >= 1, "window", "an integer >= 1", self.window)
        _require(self.in_flight == "auto" or (type(self.in_flight) is int
                                                and self.in_flight >= 1),
                 "in_flight", "an integer >= 1 or 'auto'", self.in_flight)
        _require(0.0 <= self.prior_p <= 1.0, "prior_p", "in [0, 1]", self.prior_p)
        _require(
            math.isfinite(self.probe_interval) and self.probe_interval > 0,
            "probe_interval", "> 0 seconds", self.probe_interval,
        )
        _require(
            math.isfinite(self.probe_max) and self.probe_max >= self.probe_interval,
            "probe_max", f">= probe_interval ({self.probe_interval}) seconds", self.probe_max,
        )
        _require(0.0 <= self.alpha <= 1.0, "alpha", "in [0, 1]", self.alpha)
        _require(
            math.isfinite(self.initial_weight) and self.initial_weight > 0,
            "initial_weight", "a finite number > 0", self.initial_weight,
        )
        _require(
            math.isfinite(self.weight_floor) and self.weight_floor >= 0,
            "weight_floor", "a finite number >= 0", self.weight_floor,
        )
        _require(self.max_fragments >= 1, "max_fragments", ">= 1", self.max_fragments)
        _require(self.max_update_bytes >= 1, "max_update_bytes", ">= 1", self.max_update_bytes)
        _require(self.clock_samples >= 1, "clock_samples", ">= 1", self.clock_samples)
        _require(math.isfinite(self.control_period) and self.control_period >= 0,
                 "control_period", ">= 0 seconds", self.control_period)
        _require(math.isfinite(self.timeout_floor) and self.timeout_floor > 0,
                 "timeout_floor", "> 0 seconds", self.timeout_floor)
