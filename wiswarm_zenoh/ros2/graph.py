"""rmw_zenoh's names (its design document): the data key of a topic, the liveliness
tokens under ``@ros2_lv`` that make a node, a publisher and a subscription show in
``ros2 node list`` and ``ros2 topic list``, and the attachment of every sample."""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names only: checking a namespace loads no message types
    from wiswarm_zenoh.ros2.messages import RosType

ADMIN_SPACE = "@ros2_lv"
MAX_DOMAIN = 232  # ROS_DOMAIN_ID's range
# rmw_zenoh's QoS field: reliable, volatile, keep last 10, the rest default.
DEFAULT_QOS = "::,10:,:,:,,"
GID_BYTES = 16
_ATTACHMENT = struct.Struct("<qqB")  # sequence number, source time (ns), GID length
_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def check_domain(domain: int) -> int:
    if isinstance(domain, bool) or not isinstance(domain, int) or not 0 <= domain <= MAX_DOMAIN:
        raise ValueError(f"a ROS domain is a whole number in [0, {MAX_DOMAIN}], got {domain!r}")
    return domain


def ros_token(name: str) -> str:
    """``name`` as one token of a ROS name (letters, digits, ``_``; no leading digit):
    our key chunks may hold ``.`` or ``-``, which ROS names may not."""
    token = re.sub(r"[^A-Za-z0-9_]", "_", name)
    return token if _TOKEN.fullmatch(token) else f"_{token}"


def check_namespace(namespace: str) -> str:
    """A ROS namespace: ``/`` then tokens joined by ``/``; ValueError otherwise."""
    parts = namespace.split("/")
    if parts[0] != "" or len(parts) < 2 or not all(_TOKEN.fullmatch(p) for p in parts[1:]):
        raise ValueError(f"a ROS namespace is /token[/token...] (letters, digits, _; no "
                         f"leading digit), got {namespace!r}")
    return namespace


def mangle(name: str) -> str:
    """A ROS name as one key chunk: ``/`` becomes ``%`` (the empty name is ``%``)."""
    return name.replace("/", "%") if name else "%"


def data_key(domain: int, topic: str, ros_type: RosType) -> str:
    """Where a topic's samples go: ``<domain>/<topic without leading />/<dds type>/<hash>``."""
    return f"{domain}/{topic.lstrip('/')}/{ros_type.dds_name}/{ros_type.hash}"


def topic_keys(domain: int, topic: str) -> str:
    """Every type's samples on ``topic`` (to hear, and count, a wrong type)."""
    return f"{domain}/{topic.lstrip('/')}/*/*"


@dataclass(frozen=True)
class NodeName:
    """One ROS node of a Zenoh session: its ``<domain>/<zid>/<node id>`` and name."""

    domain: int
    zid: str
    node_id: int
    namespace: str
    name: str

    @property
    def token(self) -> str:
        return (f"{ADMIN_SPACE}/{self.domain}/{self.zid}/{self.node_id}/{self.node_id}/NN/%/"
                f"{mangle(self.namespace)}/{mangle(self.name)}")

    def endpoint_token(self, entity_id: int, kind: str, topic: str, ros_type: RosType) -> str:
        """A publisher's (``MP``) or subscription's (``MS``) token."""
        return (f"{ADMIN_SPACE}/{self.domain}/{self.zid}/{self.node_id}/{entity_id}/{kind}/%/"
                f"{mangle(self.namespace)}/{mangle(self.name)}/{mangle(topic)}/"
                f"{ros_type.dds_name}/{ros_type.hash}/{DEFAULT_QOS}")


def attachment(sequence: int, source_ns: int, gid: bytes) -> bytes:
    """A sample's attachment: sequence number, source time stamp, GID."""
    return _ATTACHMENT.pack(sequence, source_ns, len(gid)) + gid



def unmangle(chunk: str) -> str:
    """A ROS name from its key chunk (``%`` back to ``/``)."""
    return chunk.replace("%", "/")


def type_name_of(dds_name: str) -> str | None:
    """``pkg/msg/Name`` of a DDS type name ``pkg::msg::dds_::Name_``; None otherwise."""
    parts = dds_name.split("::")
    if len(parts) != 4 or parts[2] != "dds_" or not parts[3].endswith("_") or \
            not all(_TOKEN.fullmatch(p) for p in (parts[0], parts[1], parts[3][:-1])):
        return None
    return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"


def check_topic(topic: str) -> str:
    """A fully qualified ROS topic name (``/token[/token...]``); ValueError otherwise."""
    try:
        return check_namespace(topic)
    except ValueError:
        raise ValueError(f"a ROS topic is /token[/token...] (letters, digits, _; no leading "
                         f"digit), got {topic!r}") from None


def source_time_ns(attachment_bytes: bytes) -> int:
    """The source time stamp (ns since the epoch) of a sample's attachment; ValueError
    for bytes that are not rmw_zenoh's attachment."""
    if len(attachment_bytes) < _ATTACHMENT.size:
        raise ValueError(f"an attachment of {len(attachment_bytes)} bytes, not rmw_zenoh's")
    _, source_ns, gid_len = _ATTACHMENT.unpack_from(attachment_bytes)
    if len(attachment_bytes) != _ATTACHMENT.size + gid_len or source_ns <= 0:
        raise ValueError("not rmw_zenoh's attachment (sequence, source time, GID)")
    return int(source_ns)
