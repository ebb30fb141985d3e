"""ROS 2 over rmw_zenoh (its design document): the leader as a ROS 2 participant, and
the pieces an application needs to map its updates to standard messages.

Each public name is listed once, as an explicit re-export (``name as name``). Importing
this is light: the message types (rosbags, the ros2 extra) load when one is first used.
"""

from wiswarm_zenoh.ros2.adapters import BytesAdapter as BytesAdapter
from wiswarm_zenoh.ros2.adapters import Output as Output
from wiswarm_zenoh.ros2.adapters import UpdateAdapter as UpdateAdapter
from wiswarm_zenoh.ros2.adapters import adapter as adapter
from wiswarm_zenoh.ros2.adapters import adapter_names as adapter_names
from wiswarm_zenoh.ros2.adapters import register_adapter as register_adapter
from wiswarm_zenoh.ros2.bridge import Ros2Bridge as Ros2Bridge
from wiswarm_zenoh.ros2.bridge import Ros2Options as Ros2Options
from wiswarm_zenoh.ros2.bridge import default_namespace as default_namespace
from wiswarm_zenoh.ros2.messages import IMAGE as IMAGE
from wiswarm_zenoh.ros2.messages import PATH as PATH
from wiswarm_zenoh.ros2.messages import POSE_STAMPED as POSE_STAMPED
from wiswarm_zenoh.ros2.messages import header as header
from wiswarm_zenoh.ros2.messages import message_class as message_class
from wiswarm_zenoh.ros2.messages import ros_type as ros_type
from wiswarm_zenoh.ros2.messages import yaw_quaternion as yaw_quaternion
from wiswarm_zenoh.ros2.node import Ros2Node as Ros2Node
from wiswarm_zenoh.ros2.node import Ros2Publisher as Ros2Publisher
from wiswarm_zenoh.ros2.topic_source import Ros2TopicSource as Ros2TopicSource
from wiswarm_zenoh.ros2.waypoints import WaypointsPublisher as WaypointsPublisher
from wiswarm_zenoh.ros2.waypoints import waypoints_path as waypoints_path
