"""The standard message definitions a third-party client needs (the ROS 2 .msg files,
comments dropped), provided by the test: the client would download them otherwise."""

from __future__ import annotations

from pathlib import Path

DEFINITIONS = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "std_msgs/msg/MultiArrayDimension": "string label\nuint32 size\nuint32 stride\n",
    "std_msgs/msg/MultiArrayLayout": "MultiArrayDimension[] dim\nuint32 data_offset\n",
    "std_msgs/msg/UInt8MultiArray": "MultiArrayLayout layout\nuint8[] data\n",
    "sensor_msgs/msg/Image": ("std_msgs/Header header\nuint32 height\nuint32 width\n"
                              "string encoding\nuint8 is_bigendian\nuint32 step\n"
                              "uint8[] data\n"),
    "geometry_msgs/msg/Point": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Quaternion": ("float64 x 0\nfloat64 y 0\nfloat64 z 0\n"
                                     "float64 w 1\n"),
    "geometry_msgs/msg/Pose": "Point position\nQuaternion orientation\n",
    "geometry_msgs/msg/PoseStamped": "std_msgs/Header header\nPose pose\n",
    "nav_msgs/msg/Path": "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses\n",
    "diagnostic_msgs/msg/KeyValue": "string key\nstring value\n",
    "diagnostic_msgs/msg/DiagnosticStatus": (
        "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\nstring name\n"
        "string message\nstring hardware_id\nKeyValue[] values\n"),
    "diagnostic_msgs/msg/DiagnosticArray": ("std_msgs/Header header\n"
                                            "DiagnosticStatus[] status\n"),
    "std_msgs/msg/String": "string data\n",
}


def write_definitions(directory: Path) -> Path:
    """Lay the definitions out as the client's registry looks for them."""
    for name, text in DEFINITIONS.items():
        path = directory / f"{name}.msg"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return directory
