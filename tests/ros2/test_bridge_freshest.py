"""Deliveries faster than the bridge publishes them: the poll thread only leaves each in
its follower's slot, the bridge's own thread publishes the freshest of each follower
(an older one still unsent is superseded, never queued) and loses none of those; close
joins that thread. With a rate limit, a follower's deliveries within its period after
the last one sent are not sent."""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence
from typing import Any

import pytest

from tests.transport.helpers import WAIT, Samples, Sessions, wait_until_known
from wiswarm_zenoh.core import Delivered
from wiswarm_zenoh.ros2 import BytesAdapter, Ros2Options, ros_type
from wiswarm_zenoh.ros2.graph import data_key
from wiswarm_zenoh.ros2.messages import UPDATE_BYTES, deserialize

SWARM = "burst"
FOLLOWERS = ("f0", "f1", "f2")
BURST = 50  # deliveries per follower while the bridge's thread is held up


class HeldAdapter(BytesAdapter):
    """Bytes, but each update waits until ``go`` is set: a publisher slower than polling."""

    def __init__(self) -> None:
        super().__init__()
        self.busy, self.go = threading.Event(), threading.Event()

    def messages(self, follower: str, update: bytes, generated_at: float) -> Sequence[Any]:
        self.busy.set()
        self.go.wait(WAIT)
        return super().messages(follower, update, generated_at)


class NoControl:
    def set_control(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None:
        raise AssertionError("no waypoints in this test")

    def expect(self, follower: str) -> None:
        raise AssertionError("no source tokens in this test")


def delivery(follower: str, seq: int, at: float | None = None) -> Delivered:
    at = 1000.0 + seq if at is None else at
    return Delivered(follower, f"{follower}:{seq}".encode(), at - 0.1, at, seq)


class Ros2Side:
    """A session for the leader's bridge, and a subscriber to every update topic it has
    heard of (so that the bridge's publishers send from the first delivery)."""

    def __init__(self, sessions: Sessions, port: int) -> None:
        sessions.router(port)
        self.leader, watcher = sessions.node(port), sessions.node(port)
        self.received = Samples(watcher, f"0/wiswarm/{SWARM}/*/update/**")
        for follower in FOLLOWERS:
            wait_until_known(self.leader, data_key(0, f"/wiswarm/{SWARM}/{follower}/update",
                                                   ros_type(UPDATE_BYTES)))

    def sent(self) -> dict[str, list[int]]:
        """The sequence numbers received, per follower, in order."""
        got: dict[str, list[int]] = {follower: [] for follower in FOLLOWERS}
        with self.received.cond:
            for sample in self.received.samples:
                follower, seq = bytes(deserialize(sample.payload.to_bytes(),
                                                  UPDATE_BYTES).data).decode().split(":")
                got[follower].append(int(seq))
        return got


@pytest.fixture
def ros2(sessions: Sessions, port: int) -> Ros2Side:
    return Ros2Side(sessions, port)


def test_a_burst_reaches_ros2_as_the_freshest_of_each_follower(ros2: Ros2Side) -> None:
    adapter = HeldAdapter()
    bridge = Ros2Options(adapter=adapter).open(ros2.leader, SWARM, NoControl())
    try:
        bridge.deliver(delivery("f0", 0))
        assert adapter.busy.wait(WAIT)  # the bridge's thread holds f0's first update
        for seq in range(1, BURST + 1):
            for follower in FOLLOWERS:
                bridge.deliver(delivery(follower, seq))  # returns at once: nothing waits
        assert bridge.superseded == len(FOLLOWERS) * (BURST - 1)
        adapter.go.set()
        ros2.received.wait("the freshest of each follower", lambda _: all(
            seqs[-1:] == [BURST] for seqs in ros2.sent().values()))
    finally:
        bridge.close()
    assert ros2.sent() == {"f0": [0, BURST], "f1": [BURST], "f2": [BURST]}
    assert bridge.published == 1 + len(FOLLOWERS)
    assert f"ros2-{SWARM}" not in {thread.name for thread in threading.enumerate()}


def test_over_the_rate_limit_a_followers_deliveries_are_not_sent(ros2: Ros2Side) -> None:
    """16 Hz: of deliveries every 1/64 s, every fourth is sent (exact binary times)."""
    bridge = Ros2Options(max_rate_hz=16).open(ros2.leader, SWARM, NoControl())
    try:
        for seq in range(17):
            bridge.deliver(delivery("f1", seq, at=1000.0 + seq / 64))
        ros2.received.wait("the last one sent", lambda _: ros2.sent()["f1"][-1:] == [16])
    finally:
        bridge.close()
    assert bridge.throttled == 12
    assert bridge.published + bridge.superseded == 5  # 0, 4, 8, 12, 16
    assert set(ros2.sent()["f1"]) <= {0, 4, 8, 12, 16}


def test_a_rate_limit_is_a_positive_number() -> None:
    for bad in (0, -1.0, math.inf, math.nan, True):
        with pytest.raises(ValueError, match="max_rate_hz"):
            Ros2Options(max_rate_hz=bad)
