"""The processes of the ROS 2 air benchmark that no program runs: a robot, and the
ground's ROS 2 subscriber that records every frame's age.

A robot is what rmw_zenoh deploys on a host: a Zenoh router of its own (connected to the
ground's across the shared channel) and a camera node publishing into it, a client of
it. The camera publishes ``sensor_msgs/msg/CompressedImage`` at 30 Hz in rmw_zenoh's
format (node and publisher tokens, CDR from rosbags, the attachment), its header stamped
at capture; with ``max_hz`` it drops frames to at most that rate at the robot, as
zenoh-bridge-ros2dds's ``pub_max_frequencies`` does. The subscriber is a ROS 2 node with
a subscription per robot; it records each frame's stamp and arrival. Every process reads
one host clock, so arrival minus stamp is the frame's age at the ground.
"""

from __future__ import annotations

import logging
import math
import os
import threading
import time
from dataclasses import dataclass
from functools import partial
from typing import Any

from wiswarm_zenoh.experiments.edge_cloud_nodes import Progress
from wiswarm_zenoh.programs.delivery_csv import DeliveryRecord
from wiswarm_zenoh.programs.runners import (
    ReadySignal,
    StopSignal,
    wait_until_stopped,
)
from wiswarm_zenoh.ros2.messages import header, message_class, seconds, serialize
from wiswarm_zenoh.ros2.node import Ros2Node
from wiswarm_zenoh.testbed.nodes import NO_SHARED_MEMORY
from wiswarm_zenoh.transport import BadInputLog
from wiswarm_zenoh.transport.zenoh_config import SessionSpec

log = logging.getLogger(__name__)

COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
CAMERA_HZ = 30.0
IMAGE_BYTES = 50_000  # each message's CDR bytes
ROBOT_PORT_BASE = 7500  # robot K's router listens on 127.0.0.1:(7500 + K)
DOMAIN = 0
THROTTLE_SLACK_S = 1e-6  # nominal frame times are sums of floats


def robot_name(index: int) -> str:
    return f"drone{index}"


def robot_router(index: int) -> str:
    """Where robot ``index``'s router listens (its nodes connect there)."""
    return f"tcp/127.0.0.1:{ROBOT_PORT_BASE + index}"


def camera_topic(index: int) -> str:
    """Robot ``index``'s camera topic, namespaced by the robot as rmw_zenoh users do."""
    return f"/{robot_name(index)}/camera/image_raw/compressed"


class Throttle:
    """Frames at most ``max_hz`` a second (None: all), by capture time: one passes once a
    period has gone since the last that passed, the rule of ``pub_max_frequencies``."""

    def __init__(self, max_hz: float | None) -> None:
        if max_hz is not None and not (math.isfinite(max_hz) and max_hz > 0):
            raise ValueError(f"max_hz must be a positive number of Hz, got {max_hz!r}")
        self._period = 0.0 if max_hz is None else 1.0 / max_hz
        self._next = -math.inf

    def passes(self, at: float) -> bool:
        if at < self._next - THROTTLE_SLACK_S:
            return False
        self._next = at + self._period
        return True


def throttled_hz(max_hz: float, camera_hz: float = CAMERA_HZ) -> float:
    """What a ``Throttle`` of ``max_hz`` passes of a ``camera_hz`` camera: every k-th
    frame, k the frames a period spans rounded up (4 Hz of 30: every 8th, 3.75 Hz)."""
    return camera_hz / max(1, math.ceil(camera_hz / max_hz - camera_hz * THROTTLE_SLACK_S))


def image_data(image_bytes: int) -> Any:
    """Random bytes (nothing on the way compresses them) as a CompressedImage's data,
    sized so that the whole CDR message is ``image_bytes`` long."""
    import numpy as np

    empty = len(serialize(camera_message(0.0, np.zeros(0, np.uint8)), COMPRESSED_IMAGE))
    if image_bytes < empty:
        raise ValueError(f"image_bytes must be >= {empty}, got {image_bytes}")
    return np.frombuffer(os.urandom(image_bytes - empty), np.uint8)


def camera_message(at: float, data: Any) -> Any:
    return message_class(COMPRESSED_IMAGE)(header=header(at, "camera"), format="jpeg",
                                           data=data)


@dataclass(frozen=True)
class RobotOptions:
    """Robot ``index`` (1-based): its router connects to ``ground`` (an endpoint);
    ``retune`` changes its throttle (to a rate, or None: off) at wall-clock times, as
    an operator re-tuning it in flight would (a mission's oracle throttle)."""

    index: int
    ground: str
    max_hz: float | None = None
    retune: tuple[tuple[float, float | None], ...] = ()
    router_cfg: tuple[str, ...] = ()  # more of the router's config (``--cfg`` items)
    rate_hz: float = CAMERA_HZ
    image_bytes: int = IMAGE_BYTES

    def router(self) -> SessionSpec:
        return SessionSpec(mode="router", listen=(robot_router(self.index),),
                           connect=(self.ground,), cfg=(NO_SHARED_MEMORY, *self.router_cfg),
                           multicast_scouting=False)

    def node(self) -> SessionSpec:
        """A node on the robot: a client of its router (it talks to that router only)."""
        return SessionSpec(mode="client", connect=(robot_router(self.index),),
                           cfg=(NO_SHARED_MEMORY,), multicast_scouting=False)


def run_robot(options: RobotOptions, stop: StopSignal, ready: ReadySignal | None = None
              ) -> None:
    """The robot's router and its camera until stopped (see the module's docstring)."""
    data = image_data(options.image_bytes)
    throttle = Throttle(options.max_hz)
    retune = sorted(options.retune)
    name = robot_name(options.index)
    with options.router().open(), options.node().open() as session:
        node = Ros2Node(session, "camera", f"/{name}", DOMAIN, BadInputLog(log))
        publisher = node.publisher(camera_topic(options.index), COMPRESSED_IMAGE)
        if ready is not None:
            ready.set()
        period, start = 1.0 / options.rate_hz, time.time()
        frame = captured = published = late = 0
        while not stop.wait(max(0.0, start + frame * period - time.time())):
            behind = math.floor((time.time() - start) / period) - frame
            if behind > 0:  # the camera's next frame time has passed too: those are lost
                late += behind
                frame += behind
            captured += 1
            while retune and retune[0][0] <= time.time():
                throttle = Throttle(retune.pop(0)[1])
            if throttle.passes(frame * period) and publisher.listening:
                publisher.publish(camera_message(time.time(), data))
                published += 1
            frame += 1
        node.close()
    log.info("%s: %d frames captured, %d published, %d missed by a late camera thread",
             name, captured, published, late)


@dataclass(frozen=True)
class ProbeOptions:
    """The ground's subscriber: ``topics`` as (robot, topic); every frame to ``record``
    (a DeliveryRecord CSV: robot, its count, stamp, arrival, data bytes); ready once the
    first frame of each robot of ``awaited`` came (None: of every robot)."""

    topics: tuple[tuple[str, str], ...]
    record: str
    awaited: tuple[str, ...] | None = None


def run_probe(spec: SessionSpec, options: ProbeOptions, stop: StopSignal,
              ready: ReadySignal | None = None) -> None:
    """The subscriber until stopped; ready once every robot's first frame came."""
    record = DeliveryRecord(options.record)
    awaited = options.awaited
    progress = Progress(list(awaited) if awaited is not None
                        else [robot for robot, _ in options.topics], ready)
    lock = threading.Lock()  # each subscription calls back on a Zenoh thread
    counts = dict.fromkeys((robot for robot, _ in options.topics), 0)

    def on_message(robot: str, message: Any) -> None:
        arrived = time.time()
        with lock:
            counts[robot] += 1
            record.row(robot, counts[robot], seconds(message.header.stamp), arrived,
                       len(message.data))
        progress.delivered(robot)

    try:
        with spec.open() as session:
            node = Ros2Node(session, "aoi_probe", "/ground", DOMAIN, BadInputLog(log))
            for robot, topic in options.topics:
                node.subscription(topic, COMPRESSED_IMAGE, partial(on_message, robot))
            wait_until_stopped(stop)
            node.close()
    finally:
        record.close()
    log.info("probe: frames received %s", counts)
