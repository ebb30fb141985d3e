"""A leader with several polls out (``--in-flight``), on real sessions on loopback: the
followers answer at once, and every one is served. (Followers sharing one process
share Zenoh's two reply threads, so K = 2 here; that no more than K are ever out is the
core's, tested in tests/core/test_in_flight.py.)"""

from __future__ import annotations

import threading
import time

import zenoh

from wiswarm_zenoh.core import LeaderConfig
from wiswarm_zenoh.transport import FollowerNode, LeaderNode

from .helpers import Recorder, Sessions

SWARM = "inflight"
K = 2


class Answering:
    """How many followers are answering a poll at the same moment, at most."""

    def __init__(self) -> None:
        self.now = self.most = 0
        self.lock = threading.Lock()

    def sample(self) -> bytes:
        with self.lock:
            self.now += 1
            self.most = max(self.most, self.now)
        time.sleep(0.02)  # the WAN's round trip, on the reply's way (not a synchronisation)
        with self.lock:
            self.now -= 1
        return b"frame"


def test_k_polls_are_out_at_once_each_to_another_follower(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    answering = Answering()
    names = [f"site.f{i}" for i in range(5)]
    for name in names:
        FollowerNode(sessions.node(port), SWARM, name, sample_on_poll=answering.sample)
    config = LeaderConfig(in_flight=K)
    with LeaderNode(sessions.node(port), SWARM, config, **recorder.callbacks()):
        recorder.wait("every follower served", lambda r: all(r.count(n) >= 10 for n in names))
    assert answering.most == K  # several at once
    for name in names:  # and each follower's updates in order, none twice
        seqs = [d.update_seq for d in recorder.deliveries if d.follower == name]
        assert seqs == sorted(set(seqs))
