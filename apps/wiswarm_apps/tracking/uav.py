"""The virtual sensing UAV: flies its waypoint plan at bounded speed and takes frames.

Flight rule (the paper's MCU reaches each waypoint at its time stamp): head for the
waypoint due next at the speed that arrives on time, never faster than `max_speed_mps`;
past the last waypoint, hold there. Yaw stays as set at start.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence

from wiswarm_apps.tracking.frames import Frame
from wiswarm_apps.tracking.geometry import CameraModel, Pose
from wiswarm_apps.tracking.render import Renderer
from wiswarm_apps.tracking.waypoints import WaypointGuard

MAX_STEP_S = 0.02  # integration step: the target moves little within one step


class WaypointFlight:
    """Pose kinematics over a guarded plan; time comes in as `now` (UAV clock)."""

    def __init__(self, start: Pose, start_time: float, guard: WaypointGuard,
                 max_speed_mps: float = 2.0) -> None:
        if not start.is_finite():
            raise ValueError(f"start pose must be finite, got {start}")
        if not (math.isfinite(max_speed_mps) and max_speed_mps > 0):
            raise ValueError(f"max_speed_mps must be positive, got {max_speed_mps!r}")
        self.guard = guard
        self.max_speed_mps = max_speed_mps
        self._pose = start
        self._t = start_time

    @property
    def pose(self) -> Pose:
        return self._pose

    def advance(self, now: float) -> Pose:
        """Fly from the last time to `now`; a clock that steps back moves nothing."""
        x, y, z, yaw = self._pose.as_tuple()
        t = self._t
        while t < now:
            t_next = min(t + MAX_STEP_S, now)
            dt = t_next - t
            target = self.guard.due_next(t)
            if target is not None:
                due, tx, ty, tz = target
                dx, dy, dz = tx - x, ty - y, tz - z
                distance = math.sqrt(dx * dx + dy * dy + dz * dz)
                speed = self.max_speed_mps
                if due - t > dt:
                    speed = min(speed, distance / (due - t))
                if distance > 1e-12:
                    fraction = min(1.0, speed * dt / distance)
                    x, y, z = x + fraction * dx, y + fraction * dy, z + fraction * dz
            t = t_next
        self._pose = Pose(x, y, z, yaw)
        self._t = max(self._t, now)
        return self._pose


class VirtualUAV:
    """A follower's UAV: waypoint flight plus a downward camera over the rendered world.

    `world_epoch` is the UAV-clock time at which world time is 0 (cars start moving).
    Thread-safe: one thread may capture while another offers plans or reads the pose.
    """

    def __init__(self, name: str, start: Pose, renderer: Renderer, start_time: float,
                 camera: CameraModel | None = None, max_speed_mps: float = 2.0,
                 world_epoch: float = 0.0) -> None:
        self.name = name
        self.renderer = renderer
        self.camera = camera if camera is not None else CameraModel()
        self.world_epoch = world_epoch
        self.guard = WaypointGuard(renderer.world.arena, name)
        self._flight = WaypointFlight(start, start_time, self.guard, max_speed_mps)
        self._lock = threading.Lock()

    def set_waypoints(self, waypoints: Sequence[Sequence[float]]) -> bool:
        """Adopt a plan (True) or reject it with a logged reason and hold (False)."""
        return self.guard.offer(waypoints)

    def pose(self, now: float) -> Pose:
        with self._lock:
            return self._flight.advance(now)

    def capture(self, now: float) -> Frame:
        """Fly to `now`, then take the frame seen from the pose at that instant."""
        pose = self.pose(now)
        pixels = self.renderer.frame(pose, self.camera, now - self.world_epoch)
        return Frame(t=now, pose=pose, camera=self.camera, pixels=pixels)
