"""The tracking application's choices as plain values (systems, vehicles, frame sizes),
apart from the modules that use them: the command line offers them without loading
the application (OpenCV, pymavlink: the tracking extra) until it runs."""

from __future__ import annotations

from typing import Literal

System = Literal["wiswarm", "push"]
SYSTEMS: tuple[System, ...] = ("wiswarm", "push")
VehicleKind = Literal["virtual", "mavlink-sim"]
VEHICLE_KINDS: tuple[VehicleKind, ...] = ("virtual", "mavlink-sim")
FRAME_SIZES = (224, 160)  # stationary runs / flights
