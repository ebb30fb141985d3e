"""The push baselines as whole programs: what ``wiswarm follower|leader --system
push|udp|tcp`` run in the foreground, and what experiments start as ``spawn`` children
(through ``run_child``, like the polling nodes of ``wiswarm_zenoh.programs.runners``)."""

from __future__ import annotations

import logging
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, replace

import zenoh

from wiswarm_zenoh.baselines.fifo import DEFAULT_CAPACITY
from wiswarm_zenoh.baselines.newest import NEWEST_SEND_BUFFER
from wiswarm_zenoh.baselines.receivers import SYSTEMS, Receiver
from wiswarm_zenoh.baselines.senders import (
    CONGESTION,
    NEWEST_ZENOH,
    PushSender,
    QueuedSender,
    TcpSender,
    UdpSender,
)
from wiswarm_zenoh.baselines.servers import DEFAULT_BIND
from wiswarm_zenoh.baselines.stamp import (
    MAX_FRAME_BYTES,
    parse_address,
    sender_id,
    udp_frame_limit,
)
from wiswarm_zenoh.programs.delivery_csv import DeliveryRecord
from wiswarm_zenoh.programs.frames import FRAME_BYTES, FRAME_HEADER_BYTES, SyntheticFrames
from wiswarm_zenoh.programs.router_watch import NoRouterReached, RouterWatch, RouterWatches
from wiswarm_zenoh.programs.runners import (
    ReadySignal,
    StopSignal,
    deadline_of,
    open_node_session,
    time_left,
    wait_until_stopped,
)
from wiswarm_zenoh.programs.ticker import MAX_RATE_HZ
from wiswarm_zenoh.ros2.newest_push import Ros2NewestPush, newest_push_cfg
from wiswarm_zenoh.ros2.topic_source import Ros2TopicSource
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.zenoh_config import SessionSpec

log = logging.getLogger(__name__)


def _check_system(system: str) -> None:
    if system not in SYSTEMS:
        raise ValueError(f"system must be one of {', '.join(SYSTEMS)}, got {system!r}")


@dataclass(frozen=True)
class BaselineFollowerOptions:
    """Followers of one host process pushing synthetic frames at ``rate`` into a FIFO of
    ``capacity`` or, ``newest_only``, a slot of one (push with congestion block, or tcp
    with SO_SNDBUF ``send_buffer``); newest-only push may push ``source``, the robot's
    ROS 2 topic, instead (``Ros2NewestPush``). Checked on construction (ValueError names
    the field)."""

    swarm: str
    follower_ids: tuple[str, ...]
    system: str  # push, udp or tcp
    rate: float
    congestion: str = "block"  # push: block or drop
    frame_bytes: int = FRAME_BYTES
    receiver: str | None = None  # udp and tcp: HOST:PORT
    capacity: int = DEFAULT_CAPACITY
    duration: float | None = None
    newest_only: bool = False
    send_buffer: int = NEWEST_SEND_BUFFER  # tcp, newest only: bytes of SO_SNDBUF
    source: Ros2TopicSource | None = None

    def __post_init__(self) -> None:
        SwarmKeys(self.swarm)
        _check_system(self.system)
        if self.newest_only and self.system == "udp":
            raise ValueError("newest_only is for push and tcp: a UDP send does not wait "
                             "for the path")
        if self.newest_only and self.congestion != "block":
            raise ValueError("newest_only needs congestion block: a dropped put would "
                             "empty the slot for nothing")
        if self.source is not None and not (self.newest_only and self.system == "push"):
            raise ValueError("a ROS 2 source is for newest-only push")
        if self.send_buffer < 1:
            raise ValueError(f"send_buffer must be >= 1 byte, got {self.send_buffer}")
        if not self.follower_ids or len(set(self.follower_ids)) != len(self.follower_ids):
            raise ValueError(f"follower_ids must be distinct and not empty: {self.follower_ids}")
        for follower in self.follower_ids:
            sender_id(follower)
        if self.congestion not in CONGESTION:
            raise ValueError(f"congestion must be block or drop, got {self.congestion!r}")
        if not 0 < self.rate <= MAX_RATE_HZ:
            raise ValueError(f"rate must be in (0, {MAX_RATE_HZ:g}], got {self.rate!r}")
        if self.capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {self.capacity}")
        if not FRAME_HEADER_BYTES <= self.frame_bytes <= MAX_FRAME_BYTES:
            raise ValueError(f"frame_bytes must be in [{FRAME_HEADER_BYTES}, {MAX_FRAME_BYTES}],"
                             f" got {self.frame_bytes}")
        if self.duration is not None and not self.duration > 0:
            raise ValueError(f"duration must be > 0, got {self.duration}")
        if self.receiver is not None:  # push has none: it goes through Zenoh
            parse_address(self.receiver)
        elif self.system != "push":
            raise ValueError(f"system {self.system} needs a receiver (HOST:PORT)")
        if self.system == "udp":
            limit = min(udp_frame_limit(f) for f in self.follower_ids)
            if self.frame_bytes > limit:
                raise ValueError(f"frame_bytes {self.frame_bytes} does not fit one UDP datagram "
                                 f"(at most {limit} with these follower ids)")


def _open_sender(session: zenoh.Session, options: BaselineFollowerOptions,
                 follower: str) -> QueuedSender | Ros2NewestPush:
    capacity = None if options.newest_only else options.capacity
    if options.source is not None:
        return Ros2NewestPush(session, options.swarm, follower, options.source)
    if options.system == "push":
        return PushSender(session, options.swarm, follower, options.congestion, capacity)
    if options.system == "udp":
        return UdpSender(follower, str(options.receiver), options.capacity)
    return TcpSender(follower, str(options.receiver), capacity,
                     send_buffer=options.send_buffer if options.newest_only else None)


def follower_session_spec(spec: SessionSpec, options: BaselineFollowerOptions,
                  follower: str) -> SessionSpec:
    """A follower's session: newest-only push keeps Zenoh's queues beneath its put small
    (``NEWEST_ZENOH``; pushing a ROS 2 topic, that topic's puts block too). The spec's
    own ``--cfg`` entries come after, and win."""
    if not (options.newest_only and options.system == "push"):
        return spec
    extra = NEWEST_ZENOH if options.source is None else newest_push_cfg(
        options.swarm, follower, options.source)
    return replace(spec, cfg=(*extra, *spec.cfg))


def run_baseline_followers(spec: SessionSpec, options: BaselineFollowerOptions,
                           stop: StopSignal, ready: ReadySignal | None = None) -> None:
    """Each follower as if on a UAV of its own: a Zenoh session (its liveliness token, so
    the receiver and other tools see who is up; for push, its publisher too) and, for
    udp/tcp, a socket. Stops when told to, or after ``duration``; ``NoRouterReached`` at
    the end if one of them never reached the router it was pointed at."""
    keys = SwarmKeys(options.swarm)
    watches = RouterWatches(spec.routers())
    deadline = deadline_of(options.duration)
    with ExitStack() as stack:
        feeds: list[tuple[str, QueuedSender | Ros2NewestPush]] = []
        for follower in options.follower_ids:
            session = stack.enter_context(open_node_session(
                follower_session_spec(spec, options, follower), f"follower {follower}", stop,
                deadline))
            watches.add(session, f"follower {follower}")
            stack.enter_context(session.liveliness().declare_token(keys.member(follower)))
            sender = _open_sender(session, options, follower)
            stack.callback(sender.close)
            feeds.append((follower, sender))
        for _, sender in feeds:
            if isinstance(sender, QueuedSender):
                frames = SyntheticFrames(sender.offer, options.frame_bytes, options.rate)
                frames.start()
                stack.callback(frames.stop)
        if ready is not None:
            ready.set()
        wait_until_stopped(stop, time_left(deadline), watches.check)
        reached = watches.finish()
        for follower, sender in feeds:
            log.info("%s: %s", follower, sender.queue.counts)
    if not reached:
        raise NoRouterReached


@dataclass(frozen=True)
class ReceiverOptions:
    """A baseline's receiver; checked on construction (ValueError names the field)."""

    swarm: str
    system: str  # push, udp or tcp
    bind: str = DEFAULT_BIND  # udp and tcp: HOST:PORT
    record: str | None = None  # CSV of every delivery (DeliveryRecord's fields)
    duration: float | None = None

    def __post_init__(self) -> None:
        SwarmKeys(self.swarm)
        _check_system(self.system)
        parse_address(self.bind)
        if self.duration is not None and not self.duration > 0:
            raise ValueError(f"duration must be > 0, got {self.duration}")


def run_receiver(spec: SessionSpec, options: ReceiverOptions, stop: StopSignal,
                 ready: ReadySignal | None = None,
                 show: Callable[[Receiver], None] | None = None) -> Receiver:
    """A baseline's receiver until stopped; ``show`` is called with it a few times a
    second. Returns the (closed) receiver, whose last stats remain readable;
    ``NoRouterReached`` instead if it never reached the router it was pointed at."""
    record = DeliveryRecord(options.record) if options.record else None
    deadline = deadline_of(options.duration)
    try:
        with open_node_session(spec, f"{options.system} receiver of {options.swarm!r}", stop,
                               deadline) as session, \
                Receiver(session, options.swarm, options.system, options.bind,
                         record=record) as receiver:
            watch = RouterWatch(session, f"{options.system} receiver of {options.swarm!r}",
                                spec.routers())
            if ready is not None:
                ready.set()

            def tick() -> None:
                watch.check()
                if show is not None:
                    show(receiver)

            wait_until_stopped(stop, time_left(deadline), tick)
            reached = watch.finish()
    finally:
        if record is not None:
            record.close()
    if not reached:
        raise NoRouterReached
    return receiver
