"""The tracking app's JSON carries what the dashboard's map draws: the UAV's pose, its
car, its camera's footprint and its waypoints (real sessions on loopback)."""

from __future__ import annotations

import json
import math
import time

import pytest

from tests.transport.helpers import Samples, Sessions, wait_until_known
from wiswarm_apps.tracking.render import Renderer
from wiswarm_apps.tracking.uav_app import SYSTEMS, System, UavOptions, UavRuntime, tracking_key
from wiswarm_apps.tracking.world import World, WorldConfig
from wiswarm_zenoh.dashboard.records import parse_tracking
from wiswarm_zenoh.transport import SwarmKeys

from .conftest import loopback

SWARM = "map"
WORLD = WorldConfig(n_cars=2, seed=3, duration_s=60)


@pytest.mark.parametrize("system", SYSTEMS)
def test_the_record_places_uav_car_footprint_and_plan_in_the_arena(
        sessions: Sessions, port: int, system: System) -> None:
    key = tracking_key(SwarmKeys(SWARM), "uav1")
    reader = Samples(sessions.open(loopback("peer", port)), key)
    options = UavOptions(swarm=SWARM, uav="uav1", car=1, world=WORLD, system=system)
    epoch = time.time()
    uav = UavRuntime(sessions.open(loopback("peer", port)), options,
                     Renderer(World(WORLD)), epoch)
    try:
        plan = [(epoch + 1.0, 5.0, 4.0, 2.0), (epoch + 2.0, 6.0, 4.5, 2.0)]
        assert uav.vehicle.set_waypoints(plan)
        wait_until_known(sessions.open(loopback("peer", port)), key)
        uav.publish_stats()
        reader.wait("the record", lambda s: bool(s.samples))
    finally:
        uav.close()
    with reader.cond:
        record = parse_tracking(json.loads(reader.samples[0].payload.to_bytes()), "uav1")
    assert record["arena"] == [WORLD.arena.width_m, WORLD.arena.height_m]
    assert record["car"] == 1
    car = World(WORLD).car_position(1, record["t"] - epoch)
    assert math.dist((record["car_x"], record["car_y"]), car) < 1e-9
    assert record["waypoints"] == [list(w) for w in plan]
    start = options.start_pose()  # where it set off to the first waypoint, at top speed
    flown = math.dist((record["x"], record["y"]), (start.x, start.y))
    assert 0 < flown <= options.max_speed_mps * (record["t"] - epoch) + 1e-6
    # The footprint: the camera's square frame on the ground, centred under the UAV.
    corners = record["footprint"]
    centre = (sum(x for x, _ in corners) / 4, sum(y for _, y in corners) / 4)
    assert math.dist(centre, (record["x"], record["y"])) < 1e-6
    side = 2 * record["z"] * math.tan(math.radians(options.camera.fov_deg) / 2)
    for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
        assert math.dist(a, b) == pytest.approx(side, rel=1e-6)
