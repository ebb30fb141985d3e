"""A member that never gives a valid answer costs the swarm almost nothing, in each way it
happens in the field: a liveliness token with no queryable, a queryable that never
replies (a hung process), one that replies garbage, and a churn of such names. Real
sessions on loopback; the three real followers answer every poll with a fresh frame.

Before the leader heard Zenoh's end of a get and judged a newcomer by the swarm's poll
times, each such member held the swarm about 0.3 s per poll for some 20 polls, and the
others fell to a few per cent of their delivery rate. What is asserted here is the
functional part (the rogue is polled a handful of times, and never holds the others'
deliveries for most of a poll's ceiling); ``bench_faults.py --cases rogue`` measures the
rates against the targets."""

from __future__ import annotations

import time
from functools import partial
from itertools import pairwise

import pytest
import zenoh

from wiswarm_zenoh.core import LeaderConfig
from wiswarm_zenoh.testbed.rogues import KINDS, churn
from wiswarm_zenoh.transport import FollowerNode, LeaderNode
from wiswarm_zenoh.transport.keys import SwarmKeys

from .helpers import Recorder, Sessions

SWARM = "ghosts"
KEYS = SwarmKeys(SWARM)
REAL = ["f0", "f1", "f2"]
FRAME = b"\x42" * 20_000
WINDOW = 1.5  # seconds measured while the rogue is there
HELD = 0.2  # s without a delivery: most of a poll's 0.3 s ceiling


@pytest.mark.parametrize("in_flight", [1, 2])
@pytest.mark.parametrize("kind", list(KINDS))
def test_a_member_that_never_answers_barely_slows_the_others(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder, kind: str,
    in_flight: int,
) -> None:
    if in_flight == 2 and kind in ("token only", "garbage"):
        pytest.skip("covered at K = 1; K = 2 is run with the kinds that hold a poll open")
    for name in REAL:
        FollowerNode(sessions.node(port, "client"), SWARM, name, sample_on_poll=lambda: FRAME)
    config = LeaderConfig(in_flight=in_flight)
    with LeaderNode(sessions.node(port, "client"), SWARM, config, every_record=True,
                    **recorder.callbacks()) as leader:
        recorder.wait("every follower served", lambda r: all(r.count(n) >= 20 for n in REAL))
        joined = time.time()
        rogue = partial(churn, period=0.25) if kind == "churn" else KINDS[kind]
        with rogue(sessions.node(port, "client"), KEYS):
            recorder.wait("the rogue joined", lambda r: any(j.startswith("ghost")
                                                            for j in r.joins))
            time.sleep(WINDOW)  # a window with the rogue there: no event ends it
            end = time.time()
            rogue_polls = sum(s.polls for s in leader.latest if s.follower.startswith("ghost"))
        held = _held(recorder, joined, end)
    # The defect's mark is the swarm held: before the fix each rogue poll stopped every
    # delivery for the 0.3 s ceiling (two such polls of a hung member in the window, six
    # with churn). A busy machine slows every poll a little and may stop this process
    # 0.2 s once; a rate compared across two windows failed on such a swing (15 % once in
    # a suite run). bench_faults.py --cases rogue measures the rates against the targets.
    assert len(held) <= 1, \
        f"{kind}: the others got nothing for {', '.join(f'{g:.2f}' for g in held)} s"
    # one poll, then probes 0.5, 1.5 s later: a handful at most, for each name
    names = sum(j.startswith("ghost") for j in recorder.joins)
    assert rogue_polls <= 3 * names


def _held(recorder: Recorder, start: float, end: float) -> list[float]:
    """The gaps of at least ``HELD`` s between the real followers' deliveries from
    ``start`` to ``end`` (the window's edges count as deliveries)."""
    with recorder.cond:
        times = sorted(d.delivered_at for d in recorder.deliveries
                       if d.follower in REAL and start <= d.delivered_at < end)
    edges = [start, *times, end]
    return [b - a for a, b in pairwise(edges) if b - a >= HELD]
