"""PX4's odometry through WiSwarm, on real processes over loopback: a flight controller's
Zenoh module (``px4.Px4``: rmw_zenoh's keys and tokens, its attachment stamped with
microseconds since the board booted) -> ``wiswarm follower --ros2-topic
/fmu/out/vehicle_odometry`` -> ``wiswarm leader --ros2`` -> a ground subscriber on the
republished topic.

Read as rmw_zenoh's nanoseconds since the epoch, the stamps would make the odometry look
56 years old. The follower maps them onto its clock: the leader's mean age of the
odometry stays under the 50 ms target, the follower says so in exactly one WARNING, and
the republished sample's attachment carries the update's generation time on the ground's
clock (within a few ms of when PX4 really published it), its CDR bytes (PX4's own
``timestamp`` field in microseconds since boot included) as PX4 published them."""

from __future__ import annotations

import json
import subprocess
import threading
import time
from typing import Any

import zenoh

from tests.ros2.px4 import TOPIC, Px4
from tests.ros2.test_ros2_sources import start
from tests.transport.helpers import WAIT, Sessions
from wiswarm_zenoh.ros2.graph import data_key, source_time_ns
from wiswarm_zenoh.transport import SwarmKeys

SWARM = "px4"
FOLLOWER = "uav1"
REPUBLISHED = f"/wiswarm/{SWARM}/{FOLLOWER}{TOPIC}"
DELIVERIES = 300  # the leader's, before its mean AoI is read: 6 s of odometry at 50 Hz
TARGET_S = 0.050  # issue 42: the leader's mean AoI of PX4-like odometry at 50 Hz
MAPPED_WITHIN_NS = 5_000_000  # a republished source time from PX4's true publish time
AFTER = 25  # republished samples looked at once the mean AoI is read (the clock mapped)


class Heard:
    """Every sample on ``key_expr`` with this host's time (ns) as it came, waitable."""

    def __init__(self, session: zenoh.Session, key_expr: str) -> None:
        self.samples: list[tuple[int, zenoh.Sample]] = []
        self.cond = threading.Condition()
        self._subscriber = session.declare_subscriber(key_expr, self._on_sample)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        came = time.time_ns()
        with self.cond:
            self.samples.append((came, sample))
            self.cond.notify_all()

    def wait(self, what: str, ready: Any, timeout: float = 3 * WAIT) -> Any:
        """The first non-None ``ready(samples)``, waiting for samples as they come."""
        with self.cond:
            found = self.cond.wait_for(lambda: ready(self.samples), timeout)
        assert found, f"timed out: {what}"
        return found


def stats_with(deliveries: int) -> Any:
    def ready(samples: list[tuple[int, zenoh.Sample]]) -> dict[str, Any] | None:
        records = [json.loads(s.payload.to_bytes()) for _, s in samples]
        return next((r for r in records if r["deliveries"] >= deliveries), None)
    return ready


def test_px4_odometry_is_fresh_at_the_leader_and_republished_on_the_grounds_clock(
        sessions: Sessions, port: int) -> None:
    sessions.router(port)
    px4 = Px4(sessions.node(port))
    ground = sessions.node(port)
    republished = Heard(ground, data_key(0, REPUBLISHED, px4.kind))
    stats = Heard(ground, SwarmKeys(SWARM).stats(FOLLOWER))
    processes: list[subprocess.Popen[str]] = []
    try:
        start(processes, port, "follower", "--swarm", SWARM, "--id", FOLLOWER,
              "--ros2-topic", TOPIC)
        start(processes, port, "leader", "--swarm", SWARM, "--ros2")
        record = stats.wait(f"{DELIVERIES} deliveries of {FOLLOWER}",
                            stats_with(DELIVERIES))
        seen = len(republished.samples)
        republished.wait(f"{AFTER} more republished samples",
                         lambda samples: len(samples) >= seen + AFTER)
        for process in processes:
            assert process.poll() is None, process.stderr.read() if process.stderr else ""
    finally:
        px4.close()
        for process in processes:
            process.terminate()
        logs = [process.communicate(timeout=WAIT)[1] for process in processes]
    err = logs[0]  # the follower's

    print(f"leader's mean AoI of PX4's odometry at 50 Hz: {record['mean_aoi_s'] * 1e3:.1f} ms "
          f"over {record['deliveries']} deliveries")
    assert record["mean_aoi_s"] < TARGET_S

    warnings = [line for line in err.splitlines() if " WARNING " in line]
    assert len(warnings) == 1, err
    assert f"follower {FOLLOWER}: ROS 2 topic {TOPIC} (domain 0): source clock is " \
        "microseconds since its boot" in warnings[0]
    assert "mapped onto this host's clock" in warnings[0]

    with republished.cond:
        heard = list(republished.samples)
    ages, errors = [], []
    for came, sample in heard:
        published = px4.published(sample.payload.to_bytes())
        assert published is not None, "republished bytes PX4 never published"
        assert sample.attachment is not None
        source_ns = source_time_ns(sample.attachment.to_bytes())
        ages.append(came - source_ns)  # what a ROS 2 subscriber makes of it
        errors.append(source_ns - published[1])
    assert all(0 <= age < 1e9 for age in ages), (min(ages), max(ages))
    late = errors[seen:]
    print(f"republished source time - PX4's publish time, ms: "
          f"{min(late) / 1e6:.3f} to {max(late) / 1e6:.3f}")
    assert all(abs(error) < MAPPED_WITHIN_NS for error in late), late
