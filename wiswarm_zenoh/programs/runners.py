"""Router, leader and follower as whole programs: what ``wiswarm router|leader|follower``
run in the foreground and what the demo, the benchmark and tests start as ``spawn``
children (through ``run_child``). Each one returns when told to stop, when its duration
is over, on Ctrl-C, or when the process that started it is gone (nothing is orphaned).
"""

from __future__ import annotations

import contextlib
import json
import logging
import multiprocessing
import signal
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import FrameType
from typing import Any, NoReturn, Protocol

import zenoh

from wiswarm_zenoh.api.follower import Follower
from wiswarm_zenoh.api.leader import Leader
from wiswarm_zenoh.core import Delivered, FollowerConfig, LeaderConfig
from wiswarm_zenoh.programs.delivery_csv import DeliveryRecord
from wiswarm_zenoh.programs.frames import (
    FRAME_BYTES,
    FRAME_RATE,
    SyntheticFrames,
)
from wiswarm_zenoh.programs.process_exit import exit_without_finalizing
from wiswarm_zenoh.programs.router_reload import ReloadingRouter
from wiswarm_zenoh.programs.router_watch import (
    STARTUP_GRACE,
    NoRouterReached,
    RouterWatch,
    RouterWatches,
    say_never_reached,
    say_unreached,
)
from wiswarm_zenoh.programs.zenoh_log import LOG_FORMAT, init_zenoh_log
from wiswarm_zenoh.ros2.waypoints import WaypointsPublisher
from wiswarm_zenoh.transport.bridge import BridgeOptions
from wiswarm_zenoh.transport.edge import Upstream
from wiswarm_zenoh.transport.streams import Stream
from wiswarm_zenoh.transport.zenoh_config import SessionSpec

log = logging.getLogger(__name__)

SUPERVISION_PERIOD = 0.25  # seconds between checks of the deadline and the parent
"""Seconds between a node's checks of its deadline and of its parent process."""


class StopSignal(Protocol):
    """``threading.Event`` or ``multiprocessing.Event``."""

    def is_set(self) -> bool:
        """Whether a stop was asked for."""

    def set(self) -> None:
        """Ask for a stop."""

    def wait(self, timeout: float | None = None) -> bool:
        """Wait up to ``timeout`` seconds for a stop; whether it was asked for."""


class ReadySignal(Protocol):
    """Set once the session is open and the node declared (an Event, or a message)."""

    def set(self) -> None:
        """Say the node is ready."""


def wait_until_stopped(stop: StopSignal, duration: float | None = None,
                       tick: Callable[[], None] | None = None) -> None:
    """Block until ``stop``, the end of ``duration``, Ctrl-C or the parent's death;
    ``tick`` runs every SUPERVISION_PERIOD meanwhile (a live display)."""
    deadline = None if duration is None else time.monotonic() + duration
    parent = multiprocessing.parent_process()
    try:
        while True:
            left = SUPERVISION_PERIOD
            if deadline is not None:
                left = min(left, deadline - time.monotonic())
            if left <= 0 or stop.wait(left):
                return
            if parent is not None and not parent.is_alive():
                log.warning("parent process is gone: stopping")
                return
            if tick is not None:
                tick()
    except KeyboardInterrupt:
        log.info("interrupted: stopping")


def deadline_of(duration: float | None) -> float | None:
    """When a run of ``duration`` seconds started now ends (``time.monotonic``)."""
    return None if duration is None else time.monotonic() + duration


def open_node_session(spec: SessionSpec, node: str, stop: StopSignal,
                      deadline: float | None) -> zenoh.Session:
    """``spec.open()``, for a node that must not depend on the order things start in: a
    client (which Zenoh opens only once its router answers) waits for its router, trying
    again, as a peer does; it says so once after ``STARTUP_GRACE``, and if ``stop``,
    ``deadline`` (``time.monotonic``) or Ctrl-C comes first, says so in one line and
    raises ``NoRouterReached``. (The open goes on in a thread, so that Ctrl-C is heard.)"""
    if not spec.waits_for_router():
        return spec.open()
    opened: list[zenoh.Session | BaseException] = []
    done = threading.Event()

    def attempt() -> None:
        try:
            opened.append(spec.open(wait_for_router=True))
        except BaseException as exc:  # handed to the caller as it is
            opened.append(exc)
        done.set()

    threading.Thread(target=attempt, name=f"open {node}", daemon=True).start()
    started, said, endpoints = time.monotonic(), False, spec.routers()
    while not done.wait(SUPERVISION_PERIOD):
        waited = time.monotonic() - started
        if stop.is_set() or (deadline is not None and time.monotonic() >= deadline):
            say_never_reached(node, endpoints, waited)
            raise NoRouterReached
        if not said and waited >= STARTUP_GRACE:
            said = True
            say_unreached(node, endpoints, waited)
    result = opened[0]
    if isinstance(result, BaseException):
        raise result
    if said:
        log.warning("%s: router reached, after %.1f s", node, time.monotonic() - started)
    return result


def time_left(deadline: float | None) -> float | None:
    """Seconds to ``deadline`` (None: no end)."""
    return None if deadline is None else max(0.0, deadline - time.monotonic())


def _interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


@contextlib.contextmanager
def sigterm_as_ctrl_c() -> Iterator[None]:
    """SIGTERM (a service manager's stop, ``kill``) ends a node as Ctrl-C does: cleanly,
    its tokens undeclared and its summary printed. Signals reach the main thread only:
    elsewhere this does nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def run_child(target: Callable[..., object], args: tuple[Any, ...],
              ready: ReadySignal, log_level: int = logging.WARNING) -> NoReturn:
    """Entry point of a ``spawn`` child: runs ``target(*args, stop, ready)`` until SIGTERM.
    Its log lines look like its parent's (``LOG_FORMAT``, at ``log_level``): a spawned
    process starts with no logging set up, and its warnings came out bare, with no time
    or level to tell them by.

    Children stop on SIGTERM (``Process.terminate()``) rather than on a shared
    ``multiprocessing.Event``: such an event is left locked for good if a process is
    killed while waiting on it. Ctrl-C reaches the whole process group, so children
    ignore it and let their parent decide. Once ``target`` has returned the child is
    finishing anyway, and ignores SIGTERM too: a parent stopping its children then would
    only cut the interpreter's shutdown short (and it would show as a crash). SIG_IGN
    holds through the interpreter's finalisation; a Python handler does not.
    The child then ends without the finalisation (``process_exit``).
    """
    logging.basicConfig(level=log_level, format=LOG_FORMAT)
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda signum, frame: stop.set())
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    code = 0
    try:
        target(*args, stop, ready)
    except NoRouterReached:  # said in its one line: no traceback, exit code 1
        code = 1
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
    exit_without_finalizing(code)  # not into a finalising interpreter: process_exit


def run_router(spec: SessionSpec, stop: StopSignal, ready: ReadySignal | None = None,
               duration: float | None = None, log_verbosity: int | None = None) -> None:
    """A Zenoh router (the session is opened in router mode) until stopped; opened again
    when its config's files change (``router_reload``). With ``log_verbosity`` (a
    ``wiswarm router`` process of its own), Zenoh's log is started here, showing what
    access control refuses (see ``zenoh_log``): it takes over the process's stdout,
    which only a process that is nothing but a router may do."""
    if log_verbosity is not None:
        init_zenoh_log(log_verbosity, denials=True)
    router = ReloadingRouter(spec)
    try:
        log.info("router %s up, listening on %s", router.session.zid(),
                 ", ".join(spec.listen) or "Zenoh's default (tcp/[::]:7447)")
        if ready is not None:
            ready.set()
        wait_until_stopped(stop, duration, router.check)
    finally:
        router.close()


@dataclass(frozen=True)
class FollowerOptions:
    """One robot's follower: synthetic frames (``frame_bytes`` at ``frame_rate``), or
    the samples of its ``streams``, each a member of its own; with ``waypoints_topic``,
    its waypoints (those of its first member) as a ROS 2 Path there (on ``ros_domain``)."""

    swarm: str
    follower_id: str
    config: FollowerConfig = field(default_factory=FollowerConfig)
    frame_bytes: int = FRAME_BYTES
    frame_rate: float = FRAME_RATE
    duration: float | None = None
    streams: tuple[Stream, ...] = ()
    waypoints_topic: str | None = None
    ros_domain: int = 0
    config_file: str | None = None  # its own Zenoh config (a certificate), over the spec's


def run_follower(spec: SessionSpec, options: FollowerOptions, stop: StopSignal,
                 ready: ReadySignal | None = None) -> None:
    """A follower sending synthetic frames until stopped; ``NoRouterReached`` at its
    end if it never reached the router it was pointed at."""
    run_followers(spec, [options], stop, ready)


def run_followers(spec: SessionSpec, options: Sequence[FollowerOptions], stop: StopSignal,
                  ready: ReadySignal | None = None) -> None:
    """Several followers in one host process, each with a Zenoh session of its own (as on
    a UAV of its own): spares the CPU of a process per follower in experiments. Stops at
    the first follower's ``duration``; ``NoRouterReached`` at the end if one of them
    never reached the router it was pointed at."""
    watches = RouterWatches(spec.routers())
    deadline = deadline_of(options[0].duration if options else None)
    with contextlib.ExitStack() as stack:
        feeds: list[tuple[str, Follower, SyntheticFrames | None]] = []
        for option in options:
            own = spec if option.config_file is None else replace(
                spec, config_file=option.config_file)
            session = stack.enter_context(open_node_session(
                own, f"follower {option.follower_id}", stop, deadline))
            watches.add(session, f"follower {option.follower_id}")
            waypoints = None if option.waypoints_topic is None else WaypointsPublisher(
                session, option.follower_id, option.waypoints_topic, option.ros_domain)
            if waypoints is not None:
                stack.callback(waypoints.close)
            if not option.streams:
                node = stack.enter_context(Follower(
                    session, option.swarm, option.follower_id, config=option.config,
                    on_control=waypoints))
                feeds.append((option.follower_id, node, SyntheticFrames(
                    node.offer, option.frame_bytes, option.frame_rate)))
            for k, stream in enumerate(option.streams):  # one session: the robot's link
                node = stack.enter_context(Follower(
                    session, option.swarm, stream.member, config=option.config,
                    source=stream.source, on_control=waypoints if k == 0 else None))
                feeds.append((stream.member, node, None))
        for _, _, synthetic in feeds:
            if synthetic is not None:
                synthetic.start()
                stack.callback(synthetic.stop)
        if ready is not None:
            ready.set()

        wait_until_stopped(stop, time_left(deadline), watches.check)
        reached = watches.finish()
        for member, node, synthetic in feeds:
            log.info("follower %s: %d %s offered, %d polls answered", member, node.offered,
                     "frames" if synthetic is not None else "samples", node.polls)
    if not reached:
        raise NoRouterReached


@dataclass(frozen=True)
class LeaderOptions:
    swarm: str
    config: LeaderConfig = field(default_factory=LeaderConfig)
    duration: float | None = None
    record: str | None = None  # CSV file of every delivery
    record_capture_stamps: bool = False  # ground-truth generation times (DeliveryRecord)
    stats_file: str | None = None  # JSON of the last stats (leader, followers), at exit
    name: str | None = None  # the leader's name among its swarm's leaders (see election)
    upstream: str | None = None  # an edge leader: the parent swarm it is a follower of
    site: str | None = None  # its name there (followers appear as <site>.<follower>)
    bridge: BridgeOptions | None = None  # e.g. the ROS 2 side (wiswarm_zenoh.ros2)
    weights: tuple[tuple[str, float], ...] = ()  # (member, weight): taken at each join


def run_leader(spec: SessionSpec, options: LeaderOptions, stop: StopSignal,
               ready: ReadySignal | None = None,
               show: Callable[[Leader], None] | None = None) -> Leader:
    """The leader until stopped; ``show`` is called with the node a few times a second.
    Returns the (closed) node, whose last stats remain readable; ``NoRouterReached``
    instead if it never reached the router it was pointed at."""
    record = (DeliveryRecord(options.record, options.record_capture_stamps)
              if options.record else None)
    deadline = deadline_of(options.duration)
    try:
        with open_node_session(spec, f"leader of {options.swarm!r}", stop, deadline) \
                as session, _edge(session, options) as upstream:
            hand_on: list[Callable[[Delivered], None]] = [] if record is None else [record]
            if upstream is not None:
                hand_on.append(upstream.on_delivery)

            def on_delivery(event: Delivered) -> None:
                for each in hand_on:
                    each(event)

            node = Leader(
                session, options.swarm, on_delivery if hand_on else None,
                config=options.config,
                on_join=None if upstream is None else upstream.on_join,
                on_leave=None if upstream is None else upstream.on_leave,
                on_role=None if upstream is None else upstream.on_role,
                name=options.name, bridge=options.bridge, weights=dict(options.weights),
                every_record=show is not None or options.stats_file is not None)
            with node:  # at once: a Ctrl-C from here on still closes it before the session
                if upstream is not None:
                    upstream.set_control = node.set_control
                reached = _lead(node, session, spec.routers(), options, stop, ready, show,
                                deadline)
        if options.stats_file is not None:
            Path(options.stats_file).write_text(json.dumps(
                {"leader": node.summary.as_dict(),
                 "followers": [stats.as_dict() for stats in node.stats]}, indent=1))
    finally:
        if record is not None:
            record.close()
    if not reached:
        raise NoRouterReached
    return node


@contextlib.contextmanager
def _edge(session: zenoh.Session, options: LeaderOptions) -> Iterator[Upstream | None]:
    """The upstream side of an edge leader (``--upstream``), or None."""
    if options.upstream is None:
        yield None
        return
    upstream = Upstream(session, options.upstream, options.site or options.swarm)
    try:
        yield upstream
    finally:
        upstream.close()


def _lead(node: Leader, session: zenoh.Session, endpoints: Sequence[str],
          options: LeaderOptions, stop: StopSignal, ready: ReadySignal | None,
          show: Callable[[Leader], None] | None, deadline: float | None) -> bool:
    """Run ``node`` until stopped; ``show`` it a few times a second. False if it never
    reached the router at ``endpoints`` (said in one line)."""
    if ready is not None:
        ready.set()
    watch = RouterWatch(session, f"leader of {options.swarm!r}", endpoints)

    def tick() -> None:
        watch.check()
        if show is not None:
            show(node)

    wait_until_stopped(stop, time_left(deadline), tick)
    return watch.finish()
