"""The secured swarm delivers as the open one does: the real LeaderNode and FollowerNodes
over the TLS router with access control, and over a plain TCP router, each follower's
frames whole and in order.

What TLS and the access rules cost is a benchmark's (``benchmarks/bench_poll.py
--secure``: 0.75 to 0.87 of an open swarm's polls, docs/measurements.md), not this
test's: on this 2-core machine with other work beside it, the median mean AoI of five
interleaved runs of each swarm came out from -36 % to +58 % of the other's, so a bound
on that ratio would hold nothing but the machine's noise."""

from __future__ import annotations

import contextlib
import struct
from collections.abc import Callable
from pathlib import Path

from tests.transport.helpers import Recorder
from wiswarm_zenoh.programs.frames import FRAME_BYTES, SyntheticFrames
from wiswarm_zenoh.transport import FollowerNode, LeaderNode, SessionSpec
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

from .helpers import SWARM, WAIT, make_swarm

FOLLOWERS = ("f1", "f2", "f3", "f4")
DELIVERIES = 20  # each follower's, in each swarm: 0.2 s of frames at 100 fps


def _delivered(specs: Callable[[str], SessionSpec]) -> Recorder:
    """What the leader reported once each follower delivered DELIVERIES frames (the
    router is up already)."""
    recorder = Recorder()
    with contextlib.ExitStack() as stack:
        for name in FOLLOWERS:
            node = stack.enter_context(FollowerNode(
                stack.enter_context(specs(name).open()), SWARM, name))
            frames = SyntheticFrames(node.offer)
            frames.start()
            stack.callback(frames.stop)
        stack.enter_context(LeaderNode(stack.enter_context(specs("leader").open()), SWARM,
                                       **recorder.callbacks()))
        recorder.wait(f"{DELIVERIES} deliveries of each follower", lambda r: all(
            r.count(name) >= DELIVERIES for name in FOLLOWERS), WAIT)
    return recorder


def test_a_secured_swarm_delivers_every_follower_as_the_open_one_does(tmp_path: Path) -> None:
    swarm = make_swarm(tmp_path / "swarm", free_tcp_port(), FOLLOWERS, ())
    open_port = free_tcp_port()

    def secured(name: str) -> SessionSpec:
        return SessionSpec(config_file=str(swarm / f"{name}.json5"))

    def plain(name: str) -> SessionSpec:
        if name == "router":
            return SessionSpec("router", listen=(f"tcp/127.0.0.1:{open_port}",),
                               multicast_scouting=False)
        return SessionSpec("client", connect=(f"tcp/127.0.0.1:{open_port}",),
                           multicast_scouting=False)

    with secured("router").open(), plain("router").open():
        for specs in (secured, plain):
            recorder = _delivered(specs)
            assert sorted(recorder.joins) == list(FOLLOWERS)
            for name in FOLLOWERS:
                frames = [d for d in recorder.deliveries if d.follower == name]
                counters = [struct.unpack_from("<Q", d.payload)[0] for d in frames]
                assert counters == sorted(set(counters))  # never an older frame after
                assert all(len(d.payload) == FRAME_BYTES for d in frames)  # whole
