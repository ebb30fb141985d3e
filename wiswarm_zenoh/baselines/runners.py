"""The push baselines as whole programs: what ``wiswarm follower|leader --system
push|udp|tcp`` run, and what the testbed starts as ``spawn`` children."""

from __future__ import annotations

import logging
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass

from wiswarm_zenoh.baselines.receivers import Receiver
from wiswarm_zenoh.baselines.senders import (
    DEFAULT_CAPACITY,
    FifoSender,
    FrameFifo,
    PushSender,
    TcpSender,
    UdpSender,
)
from wiswarm_zenoh.baselines.stamp import Stamped
from wiswarm_zenoh.transport.frames import FRAME_BYTES, SyntheticFrames
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.runners import (
    DeliveryRecord,
    ReadySignal,
    StopSignal,
    wait_until_stopped,
)
from wiswarm_zenoh.transport.zenoh_config import SessionSpec

log = logging.getLogger(__name__)

SENDERS = ("push", "udp", "tcp")
DEFAULT_BIND = "0.0.0.0:7450"


@dataclass(frozen=True)
class BaselineFollowerOptions:
    """Followers of one host process pushing synthetic frames at ``rate``."""

    swarm: str
    follower_ids: tuple[str, ...]
    system: str  # push, udp or tcp
    rate: float
    congestion: str = "block"  # push only
    frame_bytes: int = FRAME_BYTES
    receiver: str | None = None  # HOST:PORT, udp and tcp
    capacity: int = DEFAULT_CAPACITY
    duration: float | None = None

    def __post_init__(self) -> None:
        if self.system not in SENDERS:
            raise ValueError(f"system must be one of {', '.join(SENDERS)}, got {self.system!r}")
        if self.system != "push" and self.receiver is None:
            raise ValueError(f"--system {self.system} needs --to HOST:PORT (the receiver)")


def run_baseline_followers(spec: SessionSpec, options: BaselineFollowerOptions,
                           stop: StopSignal, ready: ReadySignal | None = None) -> None:
    """Each follower with a Zenoh session of its own (its liveliness token, so tools see
    who is up; for push, its publisher too) and, for udp/tcp, a socket of its own."""
    keys = SwarmKeys(options.swarm)
    with ExitStack() as stack:
        feeds: list[tuple[str, FrameFifo, SyntheticFrames]] = []
        for follower in options.follower_ids:
            session = stack.enter_context(spec.open())
            stack.enter_context(session.liveliness().declare_token(keys.member(follower)))
            sender: FifoSender
            if options.system == "push":
                sender = PushSender(session, options.swarm, follower, options.congestion,
                                    options.capacity)
            elif options.system == "udp":
                sender = UdpSender(follower, str(options.receiver), options.capacity)
            else:
                sender = TcpSender(follower, str(options.receiver), options.capacity)
            stack.callback(sender.close)
            feeds.append((follower, sender.fifo,
                          SyntheticFrames(sender.offer, options.frame_bytes, options.rate)))
        for _, _, frames in feeds:
            frames.start()
            stack.callback(frames.stop)
        if ready is not None:
            ready.set()
        wait_until_stopped(stop, options.duration)
        for follower, fifo, _ in feeds:
            log.info("%s: %d frames offered, %d sent, %d dropped by the FIFO", follower,
                     fifo.offered, fifo.sent, fifo.dropped)


@dataclass(frozen=True)
class ReceiverOptions:
    swarm: str
    system: str  # push, udp or tcp
    bind: str = DEFAULT_BIND
    record: str | None = None  # CSV of every delivery (DeliveryRecord's fields)
    duration: float | None = None
    label: str | None = None  # the leader stats' "policy" (e.g. push-block)


def run_receiver(spec: SessionSpec, options: ReceiverOptions, stop: StopSignal,
                 ready: ReadySignal | None = None,
                 show: Callable[[Receiver], None] | None = None) -> Receiver:
    """A baseline's receiver until stopped; ``show`` is called a few times a second.
    Returns the (closed) receiver, whose last stats remain readable."""
    record = DeliveryRecord(options.record) if options.record else None

    def on_frame(frame: Stamped, now: float) -> None:
        if record is not None:
            record.row(frame.follower, frame.seq, frame.generated_at, now, len(frame.payload))

    try:
        with spec.open() as session, Receiver(
                session, options.swarm, options.system, options.bind, on_frame=on_frame,
                label=options.label) as receiver:
            if ready is not None:
                ready.set()
            wait_until_stopped(stop, options.duration,
                               None if show is None else lambda: show(receiver))
    finally:
        if record is not None:
            record.close()
    return receiver
