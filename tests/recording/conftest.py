"""A small tracking swarm on loopback for the recording tests: a router, a leader and
UAV followers answering with tracking frames, in this process (shared memory off)."""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from contextlib import ExitStack
from dataclasses import dataclass

import numpy as np
import pytest
import zenoh

from tests.dashboard.conftest import loopback
from tests.transport.helpers import Recorder, Sessions
from wiswarm_apps.tracking.frames import Frame, encode_frame
from wiswarm_apps.tracking.geometry import CameraModel, Pose
from wiswarm_zenoh.core import FollowerConfig
from wiswarm_zenoh.transport import FollowerNode, LeaderNode, SwarmKeys, free_tcp_port

SWARM = "rec"
UAVS = ("uav0", "uav1")
CAMERA = CameraModel(width=32, height=24)
TRACKING = {"uav": "uav0", "t": 1.0, "arena": [4.0, 3.0], "car": 0, "car_x": 1.0, "car_y": 1.5,
            "x": 1.1, "y": 1.4, "z": 2.0, "yaw": 0.5,
            "footprint": [[0.5, 0.5], [1.5, 0.5], [1.5, 2.0], [0.5, 2.0]],
            "waypoints": [[2.0, 1.2, 1.5, 2.0]], "error_m": 0.1, "in_view": True}


def frame(index: int) -> bytes:
    pixels = np.full((CAMERA.height, CAMERA.width), 40 * index, np.uint8)
    return encode_frame(Frame(t=0.0, pose=Pose(1.0 + index, 2.0, 2.0, math.pi / 4),
                              camera=CAMERA, pixels=pixels))


@dataclass
class Swarm:
    port: int
    sessions: Sessions
    recorder: Recorder
    stack: ExitStack
    leader: LeaderNode | None = None

    def node(self) -> zenoh.Session:
        return self.sessions.open(loopback("peer", self.port))

    def start(self) -> LeaderNode:
        """The followers, then the leader."""
        for index, uav in enumerate(UAVS):
            payload = frame(index)
            self.stack.enter_context(FollowerNode(
                self.node(), SWARM, uav, FollowerConfig(),
                sample_on_poll=lambda payload=payload: payload))
        self.leader = self.stack.enter_context(
            LeaderNode(self.node(), SWARM, **self.recorder.callbacks()))
        return self.leader

    def publish_tracking(self, session: zenoh.Session, payload: bytes | None = None) -> None:
        key = f"{SwarmKeys(SWARM).prefix}/uav0/tracking"
        session.put(key, payload if payload is not None else json.dumps(TRACKING))


@pytest.fixture
def swarm() -> Iterator[Swarm]:
    port, sessions = free_tcp_port(), Sessions()
    sessions.open(loopback("router", port))
    with ExitStack() as stack:
        yield Swarm(port, sessions, Recorder(), stack)
    sessions.close_all()
