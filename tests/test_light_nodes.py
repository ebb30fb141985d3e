"""A node (router, leader, follower: what runs on a robot's small computer) loads what
nodes need, not the tracking app, the dashboard, ROS 2 or the certificate library; the
other commands still get every command's parser."""

from __future__ import annotations

import subprocess
import sys

import pytest

HEAVY = ("cv2", "matplotlib", "aiohttp", "rosbags", "foxglove", "cryptography", "pymavlink")

PROBE = """
import sys
from wiswarm_zenoh.cli.main import build_parser, commands_for
parser = build_parser(commands_for(sys.argv[1:]))
parser.parse_args(sys.argv[1:])
print(" ".join(sorted({name.split(".")[0] for name in sys.modules})))
"""


@pytest.mark.parametrize("argv", [["follower", "--id", "uav1"], ["leader"], ["router"],
                                  ["-v", "follower", "--id", "uav1", "--system", "push"],
                                  ["follower", "--id", "uav1", "--ros2-topic", "/drone1/cam"]])
def test_a_node_loads_no_heavy_library(argv: list[str]) -> None:
    loaded = subprocess.run([sys.executable, "-c", PROBE, *argv], capture_output=True,
                            text=True, check=True).stdout.split()
    assert "zenoh" in loaded
    assert [name for name in HEAVY if name in loaded] == []


def test_any_other_command_gets_every_parser() -> None:
    from wiswarm_zenoh.cli import nodes
    from wiswarm_zenoh.cli.main import commands_for, every_command

    assert commands_for(["follower", "--id", "x"]) == (nodes.register,)
    assert len(commands_for(["demo"])) == len(every_command()) > 1
    assert len(commands_for(["--help"])) == len(every_command())
