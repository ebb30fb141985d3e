"""A secured swarm and followers serving a ROS 2 topic: each follower may say what it
serves (its own source token), and the leader sees it; a follower cannot say it for
another one, so no follower makes the leader republish another's updates as its type."""

from __future__ import annotations

import zenoh

from wiswarm_zenoh.ros2.messages import RosType
from wiswarm_zenoh.ros2.topic_source import source_token

from .helpers import KEYS, Sessions, answer, flushed

KIND = RosType("sensor_msgs/msg/CompressedImage",
               "sensor_msgs::msg::dds_::CompressedImage_", "RIHS01_" + "ab" * 32)


def tokens(leader: zenoh.Session) -> set[str]:
    return {str(reply.ok.key_expr) for reply in leader.liveliness().get(KEYS.all_sources,
                                                                         timeout=2.0)
            if reply.ok is not None}


def test_a_follower_says_what_it_serves_and_only_for_itself(
        sessions: Sessions, router: zenoh.Session) -> None:
    leader, f1, f2 = (sessions.open(name) for name in ("leader", "f1", "f2"))
    mine = source_token(KEYS, "f1", "/drone1/camera", KIND)
    forged = source_token(KEYS, "f1", "/drone2/camera", KIND)
    held = [f1.liveliness().declare_token(mine), f2.liveliness().declare_token(forged)]
    serving = answer(f2, KEYS.update("f2"), b"ack")
    flushed(leader, "f2")  # f2's token was taken or refused by now
    try:
        assert tokens(leader) == {mine}
    finally:
        serving.undeclare()
        for token in held:
            token.undeclare()
