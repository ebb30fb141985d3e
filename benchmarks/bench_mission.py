"""The mission benchmark (issue 41): WiSwarm against what a ROS 2 team would run instead
while the swarm changes under them, over the testbed's tbf channel and ns-3's WiFi
medium (Linux, root). It is ``wiswarm experiment mission``: the same flags, the same
report (per phase and over the whole mission: each robot's mean and p95 AoI at the
ground's ROS 2 subscriber, the weighted mean AoI, the channel's bytes; the targets) and
figure. The standard mission is four phases of 60 s (4 robots; 4 more join; one
robot's link at a quarter; 5 leave and one robot's weight rises 4x), flown once per
system and medium, after the fixed rates are tuned by the fine search: about 90 minutes
in all, the tuning reused by a later run with the same --out.

    flock /tmp/bench.lock .venv/bin/python benchmarks/bench_mission.py --out runs/mission
    .venv/bin/python benchmarks/bench_mission.py --scenario small --media tbf
"""

from __future__ import annotations

import sys

from wiswarm_zenoh.cli.main import main

if __name__ == "__main__":
    sys.exit(main(["experiment", "mission", *sys.argv[1:]]))
