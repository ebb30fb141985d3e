"""The leader's image-processing thread (paper, Section III-D).

Frames that arrive for a UAV land in that UAV's mailbox, which keeps only the freshest
(a LIFO of one per UAV, as the paper's compute node keeps: the middleware's
``Freshest``). One vision thread takes them round robin and processes each: it finds the
UAV's car, updates the car's tracker, hands the plan to the middleware as control
information and the car-UAV relative speed as the urgency signal, and each new estimate
of the car to whoever asked (``on_estimate``: the ROS 2 side). Arrivals only swap a
reference under a lock, so the transport's thread is never held up by vision.

Clocks: arrivals carry the update's generation time on the leader's clock, frames their
capture time on the UAV's clock; the difference is the UAV's clock offset, so the plan's
waypoints are stamped in the UAV's clock (the UAV flies them by its own clock).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Protocol

from apps.tracking.frames import FrameError, decode_frame
from apps.tracking.geometry import Arena, CameraModel
from apps.tracking.tracker import CarTracker, Plan, TrackerConfig
from apps.tracking.vision import MarkerDetector
from wiswarm_zenoh.transport import BadInputLog, Freshest

log = logging.getLogger(__name__)


class ControlSink(Protocol):
    """Where plans go: the LeaderNode (polling) or the push baseline's control publisher."""

    def set_control(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None: ...

    def observe_urgency(self, follower: str, v: float) -> None: ...


@dataclass(frozen=True)
class Arrival:
    """One frame as the transport handed it over (leader clock); `counted` says whether
    it arrived inside the measurement window (only those are counted in VisionStats)."""

    payload: bytes
    generated_at: float
    received_at: float
    counted: bool = True


@dataclass(frozen=True)
class VisionStats:
    """One UAV's vision counters over the counted arrivals: frames in, processed,
    replaced unprocessed by a newer one, undecodable or of the wrong camera; sightings,
    plans handed to the middleware; and the latest plan (counted or not)."""

    car: int
    arrivals: int = 0
    processed: int = 0
    superseded: int = 0
    bad_frames: int = 0
    detections: int = 0
    plans_sent: int = 0
    plan: Plan | None = None


@dataclass(frozen=True)
class CarEstimate:
    """Where the leader estimates the car a UAV tracks is (``xy``, m) and how it moves
    (``velocity``, m/s), at ``at``: the time of the frame it was last seen in, on the
    leader's clock."""

    uav: str
    car: int
    at: float
    xy: tuple[float, float]
    velocity: tuple[float, float]


class VisionLoop:
    """Detector and one tracker per UAV on a single thread. `assignment` maps each UAV
    id to the marker id of the car it tracks; frames from other ids are refused."""

    def __init__(self, assignment: Mapping[str, int], arena: Arena,
                 tracker_config: TrackerConfig | None = None,
                 camera: CameraModel | None = None,
                 clock: Callable[[], float] = time.time) -> None:
        if not assignment:
            raise ValueError("assignment must name at least one UAV")
        self._cars = dict(assignment)
        self._trackers = {uav: CarTracker(arena, tracker_config) for uav in self._cars}
        self._camera = camera
        self._detector = MarkerDetector()  # used by the vision thread only
        self._clock = clock
        self._stats = {uav: VisionStats(car) for uav, car in self._cars.items()}
        self._mailboxes: Freshest[str, Arrival] = Freshest()
        self._lock = threading.Lock()  # the stats
        self._sink: ControlSink | None = None
        self._on_estimate: Callable[[CarEstimate], None] | None = None
        self._thread: threading.Thread | None = None
        self.busy_s = 0.0
        self.bad_input = BadInputLog(log)

    def start(self, sink: ControlSink,
              on_estimate: Callable[[CarEstimate], None] | None = None) -> None:
        """Process frames, handing plans to ``sink`` and each new car estimate (a frame
        that saw the car) to ``on_estimate``, on the vision thread, until ``stop()``."""
        if self._thread is not None:
            raise RuntimeError("vision loop already started")
        self._sink, self._on_estimate = sink, on_estimate
        self._thread = threading.Thread(target=self._run, name="vision", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._mailboxes.close()
        if self._thread is not None:
            self._thread.join()

    def submit(self, uav: str, arrival: Arrival) -> None:
        """Put a frame in its UAV's mailbox (replacing an unprocessed older one)."""
        with self._lock:
            stats = self._stats.get(uav)
            unknown = stats is None
            if stats is not None:
                waiting = self._mailboxes.put(uav, arrival)
                self._stats[uav] = replace(
                    stats, arrivals=stats.arrivals + arrival.counted,
                    superseded=stats.superseded + (waiting is not None and waiting.counted),
                )
        if unknown:
            self.bad_input.report(uav, "frame from a UAV with no car assigned")

    def stats(self) -> dict[str, VisionStats]:
        with self._lock:
            return dict(self._stats)

    def _run(self) -> None:
        while (item := self._mailboxes.take()) is not None:
            started = time.perf_counter()
            self._process(*item)
            self.busy_s += time.perf_counter() - started

    def _process(self, uav: str, arrival: Arrival) -> None:
        counted = int(arrival.counted)
        try:
            frame = decode_frame(arrival.payload, self._camera)
        except FrameError as exc:
            self._count(uav, bad_frames=counted)
            self.bad_input.report(uav, f"bad frame: {exc}")
            return
        detection = self._detector.locate(frame, self._cars[uav])
        offset = arrival.generated_at - frame.t  # leader clock minus UAV clock
        plan = self._trackers[uav].update(frame, detection, self._clock() - offset)
        fresh = detection is not None and plan.last_seen_t == frame.t
        if fresh and plan.car_xy is not None and self._on_estimate is not None:
            try:
                self._on_estimate(CarEstimate(uav, self._cars[uav], arrival.generated_at,
                                              plan.car_xy, plan.car_velocity))
            except Exception:  # logged: never the end of the vision thread
                log.exception("%s's car estimate not handed on", uav)
        sent = 0
        if detection is not None and plan.waypoints and self._sink is not None:
            try:
                self._sink.set_control(uav, plan.waypoints)
                self._sink.observe_urgency(uav, plan.urgency)
                sent = 1
            except ValueError as exc:  # the UAV left between delivery and now
                log.info("no control for %s: %s", uav, exc)
        self._count(uav, plan=plan, processed=counted,
                    detections=counted * (detection is not None), plans_sent=counted * sent)

    def _count(self, uav: str, plan: Plan | None = None, **increments: int) -> None:
        with self._lock:
            stats = self._stats[uav]
            changes = {name: getattr(stats, name) + k for name, k in increments.items()}
            self._stats[uav] = replace(stats, plan=plan or stats.plan, **changes)
