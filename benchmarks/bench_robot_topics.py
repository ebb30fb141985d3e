"""A robot's own ROS 2 topic through WiSwarm on loopback (issue 33's target: a median
age at arrival under 50 ms): N cameras publishing ``sensor_msgs/msg/CompressedImage``
at 30 Hz in rmw_zenoh's format (a process of their own), a ``wiswarm follower
--ros2-topic`` per camera, ``wiswarm leader --ros2``, all on one ``wiswarm router``
(shared memory off: ``wiswarm``'s default); here a subscriber to the leader's
republished topics measures each message's age at arrival (arrival minus its header
stamp: one host clock), and checks that the bytes are the camera's (its frame number
and size). Beside it, the same subscriber on the cameras' own topics (what a ROS 2
team does today: on loopback there is no shared air to fill, so this is the floor of
Zenoh's own path).

    .venv/bin/python benchmarks/bench_robot_topics.py
    .venv/bin/python benchmarks/bench_robot_topics.py -n 8 --seconds 20
"""

from __future__ import annotations

import argparse
import contextlib
import multiprocessing
import statistics
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Iterator

import numpy as np
import zenoh

from wiswarm_zenoh.ros2.graph import data_key
from wiswarm_zenoh.ros2.messages import header, message_class, ros_type, serialize
from wiswarm_zenoh.ros2.node import Ros2Node
from wiswarm_zenoh.transport import BadInputLog, SessionSpec, free_tcp_port

COMPRESSED = "sensor_msgs/msg/CompressedImage"
DOMAIN = 0
SWARM = "s"
RATE_HZ = 30.0
STAMP = struct.Struct("<iI")  # header.stamp after CDR's 4-byte encapsulation header
FRAME = struct.Struct("<I")  # the frame number at the start of each image's data
ENTRY = ("import sys; from wiswarm_zenoh.cli import main as m, nodes; "
         "sys.exit(m.main(registrars=(nodes.register,)))")


def topic(k: int) -> str:
    return f"/drone{k}/camera/image_raw/compressed"


def cameras(port: int, n: int, size: int, stop: multiprocessing.synchronize.Event) -> None:
    """N cameras in one process (spawn child), each a node of its own, at 30 Hz."""
    import logging

    spec = SessionSpec(mode="peer", connect=(f"tcp/127.0.0.1:{port}",),
                       multicast_scouting=False)
    with spec.open() as session:
        publishers = [Ros2Node(session, "camera", f"/drone{k}", DOMAIN,
                               BadInputLog(logging.getLogger("camera"))).publisher(
            topic(k), COMPRESSED) for k in range(1, n + 1)]
        image = message_class(COMPRESSED)
        filler = bytes(i % 251 for i in range(size - FRAME.size))
        frame = 0
        next_at = time.monotonic()
        while not stop.is_set():
            frame += 1
            for publisher in publishers:
                data = np.frombuffer(FRAME.pack(frame) + filler, np.uint8)
                message = image(header=header(time.time(), "camera"), format="jpeg", data=data)
                publisher.publish_cdr(serialize(message, COMPRESSED), time.time_ns())
            next_at += 1 / RATE_HZ
            time.sleep(max(0.0, next_at - time.monotonic()))


class Ages:
    """Each message's age at arrival, per key; whether its bytes are a camera's."""

    def __init__(self, size: int) -> None:
        self.ages: dict[str, list[float]] = {}
        self.foreign = 0  # messages whose size or content is not a camera frame's
        self._size = size
        self._lock = threading.Lock()

    def on_sample(self, sample: zenoh.Sample) -> None:
        now = time.time()
        payload = sample.payload.to_bytes()
        sec, nanosec = STAMP.unpack_from(payload, 4)
        with self._lock:
            self.ages.setdefault(str(sample.key_expr), []).append(now - sec - nanosec * 1e-9)
            self.foreign += len(payload) < self._size


def summary(ages: Ages, seconds: float) -> str:
    every = [age for per_key in ages.ages.values() for age in per_key]
    if not every:
        return "nothing received"
    rates = [len(per_key) / seconds for per_key in ages.ages.values()]
    q = statistics.quantiles(every, n=20)
    return (f"{len(ages.ages)} topics, {min(rates):.1f} to {max(rates):.1f} msgs/s each; age "
            f"at arrival median {statistics.median(every) * 1e3:.1f} ms, p95 "
            f"{q[18] * 1e3:.1f} ms; {ages.foreign} not a camera's frame")


@contextlib.contextmanager
def processes(port: int, n: int) -> Iterator[None]:
    """A router, the followers and the leader, as a user runs them."""
    endpoint = ["-e", f"tcp/127.0.0.1:{port}", "--no-multicast-scouting"]
    argvs = [["router", "-l", f"tcp/127.0.0.1:{port}", "--no-multicast-scouting"]]
    argvs += [["follower", "--swarm", SWARM, "--id", f"d{k}", "--ros2-topic", topic(k),
               *endpoint] for k in range(1, n + 1)]
    argvs += [["leader", "--swarm", SWARM, "--ros2", *endpoint]]
    started = []
    try:
        for argv in argvs:
            started.append(subprocess.Popen([sys.executable, "-c", ENTRY, *argv],
                                            stdout=subprocess.DEVNULL,
                                            stderr=subprocess.DEVNULL))
            if argv[0] == "router":
                time.sleep(1.0)  # listening before the others dial it
        yield
    finally:
        for process in started[::-1]:
            process.terminate()
        for process in started:
            process.wait(20)


def measure(session: zenoh.Session, keys: list[str], size: int, seconds: float,
            warmup: float) -> Ages:
    ages = Ages(size)
    subscribers = [session.declare_subscriber(key, ages.on_sample) for key in keys]
    time.sleep(warmup)
    ages.ages.clear()
    time.sleep(seconds)
    for subscriber in subscribers:
        subscriber.undeclare()
    return ages


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=4, help="cameras (default 4)")
    parser.add_argument("--bytes", type=int, default=50_000, help="image bytes (50 kB)")
    parser.add_argument("--seconds", type=float, default=15.0, help="each window (15 s)")
    args = parser.parse_args()
    port = free_tcp_port()
    context = multiprocessing.get_context("spawn")
    stop = context.Event()
    kind = ros_type(COMPRESSED)
    republished = [data_key(DOMAIN, f"/wiswarm/{SWARM}/d{k}{topic(k)}", kind)
                   for k in range(1, args.n + 1)]
    raw = [data_key(DOMAIN, topic(k), kind) for k in range(1, args.n + 1)]
    print(f"N = {args.n} cameras, {args.bytes} B at {RATE_HZ:g} Hz, loopback, shared memory "
          f"off, {args.seconds:g} s windows")
    with processes(port, args.n):
        camera = context.Process(target=cameras, args=(port, args.n, args.bytes, stop))
        camera.start()
        spec = SessionSpec(mode="peer", connect=(f"tcp/127.0.0.1:{port}",),
                           multicast_scouting=False)
        try:
            with spec.open() as session:
                ages = measure(session, republished, args.bytes, args.seconds, warmup=5.0)
                print(f"  WiSwarm's republished topics: {summary(ages, args.seconds)}")
                ages = measure(session, raw, args.bytes, args.seconds, warmup=2.0)
                print(f"  the cameras' own topics:      {summary(ages, args.seconds)}")
        finally:
            stop.set()
            camera.join(10)
    print("target: median age at arrival of the republished topics under 50 ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
