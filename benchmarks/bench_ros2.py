"""The ROS 2 side and the recorder against the plain leader (issue targets):

1. polls/s of the leader with ``--ros2`` (``Ros2Options``), with nobody subscribed and
   with a ROS 2 subscriber to every follower's update topic and ``/diagnostics`` (a
   process of its own, as a ROS 2 node is), against the same leader without, in
   alternating rounds (bench_poll's followers and rounds): target >= 0.95 (0.90
   subscribed); and what
   each costs in CPU: the leader's process (this one) per poll, the subscriber's per
   sample; then the same subscribed, with each follower's updates sent at most
   ``--max-rate`` times a second (``Ros2Options.max_rate_hz``, ``--ros-max-rate``);
2. in those rounds, how long after its delivery (the leader's ``delivered_at``) each
   update reaches that subscriber (on the rmw_zenoh data keys): target median <= 5 ms
   on loopback. There each update goes out as the tracking demo's frames do, a
   ``sensor_msgs/msg/Image`` stamped with its generation time (``StampedUpdates``), by
   which the subscriber finds the delivery each sample is;
3. ``SwarmRecording`` (``wiswarm record``) of a swarm at full rate: the deliveries in the
   MCAP file against the leader's own, from the first one recorded: target nothing lost.

    .venv/bin/python benchmarks/bench_ros2.py            # N = 14, 50 kB frames
    .venv/bin/python benchmarks/bench_ros2.py -n 4 --rounds 4
    .venv/bin/python benchmarks/bench_ros2.py --kinds capped   # plain and capped only
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import statistics
import struct
import tempfile
import threading
import time
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import numpy as np
import zenoh
from bench_poll import (
    SWARM,
    children,
    followers_process,
    leader_round,
    wait_for_routes,
)
from mcap.reader import make_reader

from wiswarm_zenoh.core import Delivered, LeaderConfig
from wiswarm_zenoh.programs.runners import run_router
from wiswarm_zenoh.recording import SwarmRecording
from wiswarm_zenoh.ros2 import IMAGE, Output, Ros2Options, header, message_class
from wiswarm_zenoh.transport import SessionSpec
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

NO_SHM = ("transport/shared_memory/enabled:false",)
STAMP = struct.Struct("<4xiI")  # a CDR message's header stamp: encapsulation, sec, nanosec
Sample = tuple[str, int, float]  # follower, header stamp (ns), received at
KINDS = ["quiet", "subscribed", "capped"]


class StampedUpdates:
    """Each update as a one-row ``mono8`` image stamped with its generation time."""

    outputs = (Output("update", IMAGE),)

    def messages(self, follower: str, update: bytes, generated_at: float) -> list[Any]:
        return [message_class(IMAGE)(
            header=header(generated_at), height=1, width=len(update), encoding="mono8",
            is_bigendian=0, step=len(update), data=np.frombuffer(update, np.uint8))]


class RosSubscriber:
    """Every sample on the followers' update topics: (follower, stamp, received at)."""

    def __init__(self, session: zenoh.Session) -> None:
        self.samples: list[Sample] = []
        self._subscribers = [session.declare_subscriber(key, self._on_sample) for key in (
            f"0/wiswarm/{SWARM}/*/update/*/*", "0/diagnostics/*/*")]

    def _on_sample(self, sample: zenoh.Sample) -> None:
        now = time.time()
        parts = str(sample.key_expr).split("/")
        if parts[-3] == "update":
            sec, nanosec = STAMP.unpack_from(sample.payload.to_bytes())
            self.samples.append((parts[3], sec * 10**9 + nanosec, now))

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.undeclare()


def run_subscriber(spec: SessionSpec, pipe: Connection) -> None:
    """A ROS 2 subscriber process: ready when its subscribers are declared; what it got,
    and the CPU time it took since, go back when the pipe says stop."""
    with spec.open() as session:
        subscriber = RosSubscriber(session)
        pipe.send("ready")
        start = time.process_time()
        pipe.recv()
        subscriber.close()
        pipe.send((subscriber.samples, time.process_time() - start))


class SubscriberProcess:
    def __init__(self, spec: SessionSpec) -> None:
        context = multiprocessing.get_context("spawn")
        self._pipe, theirs = context.Pipe()
        self._process = context.Process(target=run_subscriber, args=(spec, theirs))
        self._process.start()
        assert self._pipe.recv() == "ready"

    def stop(self) -> tuple[list[Sample], float]:
        """The samples it got, and its CPU time (s)."""
        self._pipe.send("stop")
        got: tuple[list[Sample], float] = self._pipe.recv()
        self._process.join()
        return got


class LastBatch:
    """The latest ``delivered_at`` in the leader's delivery stream, waitable."""

    def __init__(self, session: zenoh.Session) -> None:
        self._latest = 0.0
        self._cond = threading.Condition()
        self._subscriber = session.declare_subscriber(
            f"wiswarm/{SWARM}/leader/deliveries", self._on_sample)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        with self._cond:
            self._latest = max([self._latest, *(r["delivered_at"] for r in json.loads(
                sample.payload.to_bytes()))])
            self._cond.notify_all()

    def wait_for(self, delivered_at: float) -> bool:
        with self._cond:
            return self._cond.wait_for(lambda: self._latest >= delivered_at, 10.0)


def latencies(delivered: dict[tuple[str, int], float], got: list[Sample]) -> list[float]:
    """Each sample's delay after its delivery, found by the sample's stamp (the
    update's generation time, in ns)."""
    return [at - delivered[follower, stamp] for follower, stamp, at in got]


@dataclass
class Kind:
    """One kind of leader round, and what its rounds measured."""

    title: str
    bridge: Ros2Options | None = None
    subscribed: bool = False  # a ROS 2 subscriber process on every update topic
    rates: list[float] = field(default_factory=list)  # polls/s
    cpu: list[float] = field(default_factory=list)  # this process's CPU per poll, s
    delays: list[float] = field(default_factory=list)  # delivery to subscriber, s
    made: int = 0  # deliveries while subscribed
    sent: int = 0  # samples the subscriber got
    subscriber_cpu: float = 0.0  # its CPU time, s


def run_round(session: zenoh.Session, spec: SessionSpec, n: int, args: argparse.Namespace,
              kind: Kind) -> None:
    delivered: dict[tuple[str, int], float] = {}

    def on_delivery(event: Delivered) -> None:
        delivered[event.follower, round(event.generated_at * 1e9)] = event.delivered_at

    subscriber = SubscriberProcess(spec) if kind.subscribed else None
    start = time.process_time()
    rate, stats, _ = leader_round(session, n, args.seconds, LeaderConfig(),
                                  bridge=kind.bridge, on_delivery=on_delivery)
    kind.rates.append(rate)
    kind.cpu.append((time.process_time() - start) / sum(int(s["polls"]) for s in stats))
    if subscriber is not None:
        got, cpu = subscriber.stop()
        kind.delays += latencies(delivered, got)
        kind.made, kind.sent = kind.made + len(delivered), kind.sent + len(got)
        kind.subscriber_cpu += cpu


def measure(n: int, args: argparse.Namespace) -> None:
    port = free_tcp_port()
    spec = SessionSpec(mode="peer", connect=(f"tcp/127.0.0.1:{port}",),
                       listen=("tcp/127.0.0.1:0",), multicast_scouting=False, cfg=NO_SHM)
    router = SessionSpec(mode="router", listen=(f"tcp/127.0.0.1:{port}",),
                         multicast_scouting=False, cfg=NO_SHM)
    followers = [f"uav{i}" for i in range(n)]
    compared = {
        "quiet": Kind("--ros2, nobody subscribed", Ros2Options()),
        "subscribed": Kind("--ros2, a ROS 2 subscriber to every topic",
                           Ros2Options(adapter=StampedUpdates()), subscribed=True),
        "capped": Kind(f"--ros2 --ros-max-rate {args.max_rate:g}, the same subscriber",
                       Ros2Options(adapter=StampedUpdates(), max_rate_hz=args.max_rate),
                       subscribed=True)}
    kinds = [Kind("leader"), *(compared[name] for name in args.kinds)]
    with children([(run_router, (router,)), (followers_process, (
            [spec] * n, followers, args.frame_bytes, None, True))]), spec.open() as session:
        wait_for_routes(session, followers, LeaderConfig().timeout)
        for i in range(args.rounds):
            for kind in kinds if i % 2 == 0 else kinds[::-1]:
                run_round(session, spec, n, args, kind)
        print(f"N = {n}, {args.frame_bytes} B updates, {args.rounds} rounds of each, "
              f"{args.seconds} s, shared memory off")
        plain = kinds[0]
        print(f"  leader             {statistics.median(plain.rates):8.0f} polls/s, this "
              f"process's CPU {statistics.median(plain.cpu) * 1e6:.0f} µs per poll")
        for kind in kinds[1:]:
            ratios = sorted(b / p for p, b in zip(plain.rates, kind.rates, strict=True))
            q1, median, q3 = statistics.quantiles(ratios, n=4)
            print(f"  leader {kind.title}: {statistics.median(kind.rates):.0f} polls/s, "
                  f"ratio {median:.3f} (quartiles {q1:.3f} .. {q3:.3f})   target >= "
                  f"{0.90 if kind.subscribed else 0.95:.2f}; "
                  f"CPU {statistics.median(kind.cpu) * 1e6:.0f} µs per poll")
            if kind.subscribed:
                delays = kind.delays
                p50, p95 = statistics.median(delays), statistics.quantiles(delays, n=20)[18]
                print(f"    delivery -> ROS 2 subscriber: median {p50 * 1e3:.2f} ms, p95 "
                      f"{p95 * 1e3:.2f} ms, min {min(delays) * 1e3:.2f} ms over "
                      f"{len(delays)} updates ({kind.sent} of the {kind.made} deliveries "
                      f"reached it; it took {kind.subscriber_cpu / kind.sent * 1e6:.0f} µs "
                      "of CPU per sample)   target median <= 5 ms")
        record(session, spec, n, args)


def record(session: zenoh.Session, spec: SessionSpec, n: int, args: argparse.Namespace) -> None:
    """The recorder on a session of its own during a leader round; then the file's
    deliveries against the leader's, from the first recorded on."""
    made: list[tuple[str, float]] = []
    with tempfile.TemporaryDirectory() as directory, spec.open() as watcher:
        path = Path(directory) / "run.mcap"
        recording = SwarmRecording(watcher, SWARM, mcap=path)
        batches = LastBatch(watcher)  # on the recording's session: it hears the same
        start = time.perf_counter()
        rate = leader_round(session, n, args.record_seconds, LeaderConfig(),
                            on_delivery=lambda e: made.append((e.follower, e.delivered_at)))[0]
        if not batches.wait_for(made[-1][1]):
            print("  the leader's last batch of deliveries never came")
        recording.close()
        elapsed = time.perf_counter() - start
        with path.open("rb") as file:
            recorded = [(m["follower"], m["delivered_at"]) for m in (
                json.loads(message.data) for _, channel, message
                in make_reader(file).iter_messages(topics=[f"/wiswarm/{SWARM}/deliveries"]))
                if m["outcome"] == "delivered"]
        size = path.stat().st_size
    first = made.index(recorded[0])
    missing = len(made) - first - len(recorded)
    print(f"  wiswarm record: {len(recorded)} deliveries in the file, the leader made "
          f"{len(made) - first} from the first recorded on: {missing} missing "
          f"({rate:.0f} polls/s, {len(recorded) / elapsed:.0f} deliveries/s recorded, "
          f"{size / 1e6:.1f} MB)   target 0 missing")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", "--followers", type=int, nargs="+", default=[14])
    parser.add_argument("--frame-bytes", type=int, default=50176)
    parser.add_argument("--seconds", type=float, default=1.5, help="length of each round")
    parser.add_argument("--rounds", type=int, default=8, help="pairs of rounds")
    parser.add_argument("--record-seconds", type=float, default=10.0)
    parser.add_argument("--max-rate", type=float, default=20.0,
                        help="Hz: each follower's updates to ROS 2 at most, in 'capped'")
    parser.add_argument("--kinds", nargs="+", default=KINDS, choices=KINDS,
                        help="the rounds to pair with the plain leader's (fewer: closer pairs)")
    args = parser.parse_args()
    for n in args.followers:
        measure(n, args)


if __name__ == "__main__":
    main()
