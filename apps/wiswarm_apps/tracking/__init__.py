"""Mobility tracking: a simulated world of cars, virtual UAV cameras, ArUco vision,
waypoint planning and a MAVLink link, as in Sections III-IV of the WiSwarm paper."""
