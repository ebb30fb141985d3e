"""Deliveries faster than the bridge publishes them: the poll thread only leaves each in
its follower's slot, the bridge's own thread publishes the freshest of each follower
(an older one still unsent is superseded, never queued) and loses none of those; close
joins that thread."""

from __future__ import annotations

import threading
from collections.abc import Sequence
from typing import Any

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


def delivery(follower: str, seq: int) -> Delivered:
    return Delivered(follower, f"{follower}:{seq}".encode(), 1000.0 + seq, 1000.1 + seq, seq)


def test_a_burst_reaches_ros2_as_the_freshest_of_each_follower(sessions: Sessions,
                                                                port: int) -> None:
    sessions.router(port)
    leader, watcher = sessions.node(port), sessions.node(port)
    received = Samples(watcher, f"0/wiswarm/{SWARM}/*/update/**")
    for follower in FOLLOWERS:
        wait_until_known(leader, data_key(0, f"/wiswarm/{SWARM}/{follower}/update",
                                          ros_type(UPDATE_BYTES)))
    adapter = HeldAdapter()
    bridge = Ros2Options(adapter=adapter).open(leader, SWARM, NoControl())
    try:
        bridge.deliver(delivery("f0", 0))
        assert adapter.busy.wait(WAIT)  # the bridge's thread holds f0's first update
        for seq in range(1, BURST + 1):
            for follower in FOLLOWERS:
                bridge.deliver(delivery(follower, seq))  # returns at once: nothing waits
        assert bridge.superseded == len(FOLLOWERS) * (BURST - 1)
        adapter.go.set()

        def sent() -> dict[str, list[int]]:
            got: dict[str, list[int]] = {follower: [] for follower in FOLLOWERS}
            for sample in received.samples:
                follower, seq = bytes(deserialize(sample.payload.to_bytes(),
                                                  UPDATE_BYTES).data).decode().split(":")
                got[follower].append(int(seq))
            return got

        received.wait("the freshest of each follower", lambda _: all(
            seqs[-1:] == [BURST] for seqs in sent().values()))
    finally:
        bridge.close()
    assert sent() == {"f0": [0, BURST], "f1": [BURST], "f2": [BURST]}
    assert bridge.published == 1 + len(FOLLOWERS)
    assert f"ros2-{SWARM}" not in {thread.name for thread in threading.enumerate()}
