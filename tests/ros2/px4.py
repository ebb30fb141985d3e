"""A PX4 flight controller's odometry as its Zenoh module publishes it (PX4 v1.17+,
``src/modules/zenoh``), written from that module's source:

- the data key ``<domain><topic>/px4_msgs::msg::dds_::<Type>_/RIHS01_<hash>``
  (``generate_rmw_zenoh_topic_keyexpr``), the hash and the CDR bytes computed here with
  rosbags from ``px4_msgs/VehicleOdometry.msg`` beside this file;
- the node's liveliness token ``@ros2_lv/0/<zid>/0/0/NN/%/%/px4_<guid>`` (domain 0, as
  PX4 writes it) and the publisher's ``@ros2_lv/<domain>/<zid>/0/11/MP/%/%/px4_<guid>/
  <topic, / as %>/<type>/<hash>/::,7:,:,:,,``;
- each sample's attachment, rmw_zenoh's 33 bytes (``rmw_attachment.h``): the sequence
  number, ``hrt_absolute_time()`` (microseconds since the board booted) and the board's
  16-byte GUID as the GID.

The fake board booted ``booted_s_ago`` before it started, on this host's clock, so each
sample's true publish time is known: ``sent`` maps its CDR bytes to (stamp, time)."""

from __future__ import annotations

import os
import struct
import threading
import time
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import zenoh

from wiswarm_zenoh.ros2.graph import mangle
from wiswarm_zenoh.ros2.messages import RosType
from wiswarm_zenoh.transport.entities import undeclare

MSG = Path(__file__).parent / "px4_msgs" / "VehicleOdometry.msg"
TYPE = "px4_msgs/msg/VehicleOdometry"
TOPIC = "/fmu/out/vehicle_odometry"
ATTACHMENT = struct.Struct("<qqB")  # int64 sequence_number, int64 time, uint8 gid size


@cache
def _store() -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(MSG.read_text(), TYPE))
    return store


def odometry_type() -> RosType:
    return RosType(TYPE, "px4_msgs::msg::dds_::VehicleOdometry_", _store().hash_rihs01(TYPE))


def odometry(k: int, hrt_us: int) -> bytes:
    """The CDR bytes of odometry sample ``k``, its own stamps a little before ``hrt_us``
    (the estimator's, before the Zenoh module took it from uORB)."""
    def floats(*values: float) -> Any:
        return np.array(values, dtype=np.float32)

    message = _store().types[TYPE](
        timestamp=hrt_us - 400, timestamp_sample=hrt_us - 2_500, pose_frame=1,
        position=floats(0.01 * k, -0.02 * k, -10.0), q=floats(1, 0, 0, 0), velocity_frame=1,
        velocity=floats(0.5, -1.0, 0), angular_velocity=floats(0, 0, 0.1),
        position_variance=floats(0.01, 0.01, 0.02), orientation_variance=floats(1e-4, 1e-4, 1e-3),
        velocity_variance=floats(0.02, 0.02, 0.04), reset_counter=0, quality=0)
    return bytes(_store().serialize_cdr(message, TYPE))


class Px4:
    """The board's Zenoh module on ``session``, publishing odometry at ``rate_hz`` from its
    own thread until ``close()``."""

    def __init__(self, session: zenoh.Session, domain: int = 0, rate_hz: float = 50.0,
                 booted_s_ago: float = 1234.0) -> None:
        self.kind = odometry_type()
        self.key = f"{domain}{TOPIC}/{self.kind.dds_name}/{self.kind.hash}"
        self.boot_ns = time.time_ns() - round(booted_s_ago * 1e9)
        self.sent: dict[bytes, tuple[int, int]] = {}  # CDR: (hrt µs, publish time ns)
        self._guid = os.urandom(16)
        zid, guid = str(session.info.zid()), self._guid.hex()
        self._tokens = [session.liveliness().declare_token(key) for key in (
            f"@ros2_lv/0/{zid}/0/0/NN/%/%/px4_{guid}",
            f"@ros2_lv/{domain}/{zid}/0/11/MP/%/%/px4_{guid}/{mangle(TOPIC)}/"
            f"{self.kind.dds_name}/{self.kind.hash}/::,7:,:,:,,")]
        self._publisher = session.declare_publisher(self.key)
        self._period = 1.0 / rate_hz
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def published(self, cdr: bytes) -> tuple[int, int] | None:
        with self._lock:
            return self.sent.get(cdr)

    def _run(self) -> None:
        sequence, next_at = 0, time.monotonic()
        while not self._stop.wait(max(0.0, next_at - time.monotonic())):
            next_at += self._period
            sequence += 1
            cdr = odometry(sequence, (time.time_ns() - self.boot_ns) // 1000)
            now = time.time_ns()
            hrt_us = (now - self.boot_ns) // 1000  # hrt_absolute_time(), at the put
            with self._lock:
                self.sent[cdr] = (hrt_us, now)
            self._publisher.put(cdr, attachment=ATTACHMENT.pack(sequence, hrt_us, 16)
                                + self._guid)

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        undeclare(*self._tokens, self._publisher)
