"""A robot's camera as rmw_zenoh publishes it, without ROS 2 installed: a node
``/<ns>/camera`` with its liveliness tokens, and ``sensor_msgs/msg/CompressedImage``
frames at --rate on --topic, CDR with rmw_zenoh's attachment (the source time). A
``wiswarm follower --ros2-topic`` takes it as it would a real ROS 2 camera's topic; try
the guide's commands with it before the robot is at hand. Needs the ros2 extra.

    python examples/camera_ros2.py --topic /drone1/camera/image_raw/compressed
"""

from __future__ import annotations

import time

import numpy as np
from common import end_time, open_session, parser, run

from wiswarm_zenoh.ros2 import Ros2Node, header, message_class

COMPRESSED = "sensor_msgs/msg/CompressedImage"


def main() -> None:
    flags = parser("A camera publishing CompressedImage frames in rmw_zenoh's format.")
    flags.add_argument("--topic", default="/drone1/camera/image_raw/compressed",
                       help="the full topic name (default /drone1/camera/image_raw/compressed)")
    flags.add_argument("--rate", type=float, default=30.0, help="frames per second")
    flags.add_argument("--bytes", type=int, default=50_000, help="bytes per frame")
    flags.add_argument("--domain", type=int, default=0, help="the ROS domain (default 0)")
    args = flags.parse_args()
    namespace = "/" + args.topic.strip("/").split("/")[0]
    end = end_time(args)
    with open_session(args) as session:
        node = Ros2Node(session, "camera", namespace, args.domain)
        camera = node.publisher(args.topic, COMPRESSED)
        print(f"camera {namespace}/camera: {args.bytes}-byte frames at {args.rate:g} Hz on "
              f"{args.topic} (Ctrl-C to stop)", flush=True)
        frame = 0
        try:
            while time.monotonic() < end:
                frame += 1
                pixels = np.full(args.bytes, frame % 256, np.uint8)
                camera.publish(message_class(COMPRESSED)(
                    header=header(time.time(), "camera"), format="jpeg", data=pixels))
                time.sleep(1 / args.rate)  # the camera's pace, not a wait for anything
        finally:  # at Ctrl-C too
            node.close()
            print(f"{frame} frames taken", flush=True)


if __name__ == "__main__":
    run(main)
