"""The secured swarm delivers as the open one does: the real LeaderNode and FollowerNodes
over the TLS router with access control, and over a plain TCP router."""

from __future__ import annotations

import contextlib
import statistics
import threading
import time
from collections.abc import Callable
from pathlib import Path

from wiswarm_zenoh.programs.frames import SyntheticFrames
from wiswarm_zenoh.transport import FollowerNode, LeaderNode, SessionSpec
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

from .helpers import SWARM, WAIT, make_swarm

N = 4
FOLLOWERS = tuple(f"f{i}" for i in range(1, N + 1))
RUN = 1.2  # seconds of polling per measurement (about 2000 polls)
ROUNDS = 5
# The secured configs keep shared memory off (traffic takes the link); so does the open
# swarm here, or this would compare TLS with shared memory.
NO_SHM = ("transport/shared_memory/enabled:false",)


def _mean_aoi(specs: Callable[[str], SessionSpec]) -> float:
    """The leader's mean AoI over all followers after RUN seconds of polling (the
    router is up already)."""
    joined = threading.Semaphore(0)
    with contextlib.ExitStack() as stack:
        for name in FOLLOWERS:
            node = stack.enter_context(FollowerNode(
                stack.enter_context(specs(name).open()), SWARM, name))
            frames = SyntheticFrames(node.offer)
            frames.start()
            stack.callback(frames.stop)
        leader = stack.enter_context(LeaderNode(
            stack.enter_context(specs("leader").open()), SWARM, every_record=True,
            on_join=lambda follower: joined.release()))
        for _ in FOLLOWERS:
            assert joined.acquire(timeout=WAIT), "a follower never joined"
        time.sleep(RUN)  # the measurement itself, not a synchronisation
        summary = leader.summary
        assert sorted(summary.followers) == list(FOLLOWERS)
        assert all(r.deliveries > 0 for r in leader.latest)
        return summary.mean_aoi_s


def test_secured_swarm_delivers_with_the_aoi_of_the_open_one(tmp_path: Path) -> None:
    swarm = make_swarm(tmp_path / "swarm", free_tcp_port(), FOLLOWERS, ())
    open_port = free_tcp_port()

    def secured(name: str) -> SessionSpec:
        return SessionSpec(config_file=str(swarm / f"{name}.json5"))

    def plain(name: str) -> SessionSpec:
        if name == "router":
            return SessionSpec("router", listen=(f"tcp/127.0.0.1:{open_port}",),
                               multicast_scouting=False, cfg=NO_SHM)
        return SessionSpec("client", connect=(f"tcp/127.0.0.1:{open_port}",),
                           multicast_scouting=False, cfg=NO_SHM)

    means: dict[str, list[float]] = {"secured": [], "open": []}
    with secured("router").open(), plain("router").open():
        for _ in range(ROUNDS):  # interleaved: a busy moment of the machine hits both
            means["secured"].append(_mean_aoi(secured))
            means["open"].append(_mean_aoi(plain))
    secure, plain_aoi = statistics.median(means["secured"]), statistics.median(means["open"])
    print(f"mean AoI (ms): secured {[round(m * 1e3, 3) for m in means['secured']]}, "
          f"open {[round(m * 1e3, 3) for m in means['open']]}; medians "
          f"{secure * 1e3:.3f} vs {plain_aoi * 1e3:.3f} ({secure / plain_aoi - 1:+.1%})")
    assert secure <= 1.10 * plain_aoi
