"""A swarm's keys as Foxglove channels: each sample from the swarm (checked as the
dashboard checks it) becomes a typed message on its channel, in a Foxglove context that
any sink reads (an MCAP file, the live WebSocket server).

Channels, under ``/wiswarm/<swarm>``: ``deliveries`` (one message per delivery or
unanswered poll, at its time on the leader's clock), ``<follower>/stats`` and
``leader/stats``, ``control``, ``<uav>/tracking`` (JSON, schemas in ``schemas``);
``arena`` (``foxglove.SceneUpdate``) and ``log`` (``foxglove.Log``: members and leaders
coming and going, the active leader changing); with an update adapter, each delivered
frame as ``<follower>/image`` (``foxglove.CompressedImage``, PNG) and pose as
``<follower>/pose`` (``foxglove.PoseInFrame``)."""

from __future__ import annotations

import logging
import threading
import time
from collections import Counter
from collections.abc import Callable
from typing import Any

import numpy as np
import zenoh
from foxglove import Channel, Context
from foxglove.channels import (
    CompressedImageChannel,
    LogChannel,
    PoseInFrameChannel,
    SceneUpdateChannel,
)
from foxglove.messages import (
    CompressedImage,
    Log,
    LogLevel,
    Pose,
    PoseInFrame,
    Quaternion,
    Timestamp,
    Vector3,
)

from wiswarm_zenoh.core.wire import decode_control
from wiswarm_zenoh.dashboard.feed import TRACKING_LEAF
from wiswarm_zenoh.dashboard.records import (
    parse_deliveries,
    parse_leader,
    parse_stats,
    parse_tracking,
)
from wiswarm_zenoh.extras import require
from wiswarm_zenoh.recording import schemas
from wiswarm_zenoh.recording.scene import arena_update
from wiswarm_zenoh.ros2 import IMAGE, POSE_STAMPED, UpdateAdapter
from wiswarm_zenoh.transport import BadInputLog, SwarmKeys
from wiswarm_zenoh.transport.watch import Handler, TokenHandler, json_payload, loads

log = logging.getLogger(__name__)
NS_PER_S = 1_000_000_000


def _ns(seconds: float) -> int:
    return round(seconds * NS_PER_S)


class SwarmChannels:
    """The channels of ``swarm`` in ``context``, made as their first message comes;
    ``counts`` says how many messages each got."""

    def __init__(self, context: Context, swarm: str, adapter: UpdateAdapter | None = None,
                 clock: Callable[[], float] = time.time) -> None:
        self.keys = SwarmKeys(swarm)
        self.root = f"/wiswarm/{swarm}"
        self.counts: Counter[str] = Counter()
        self.bad_input = BadInputLog(log)
        self._context = context
        self._adapter = adapter
        self._clock = clock
        self._channels: dict[str, Any] = {}
        self._lock = threading.Lock()
        self._active: tuple[str, int] | None = None  # the active leader and its epoch
        if adapter is not None and any(out.type_name == IMAGE for out in adapter.outputs):
            require("tracking")  # images are PNG-encoded with OpenCV (_png)

    def handlers(self) -> dict[str, Handler]:
        """What to subscribe to, and what each sample becomes."""
        handlers = {self.keys.leader_deliveries: json_payload(self._on_deliveries),
                    self.keys.all_stats: json_payload(self._on_stats),
                    f"{self.keys.prefix}/*/{TRACKING_LEAF}": json_payload(self._on_tracking),
                    self.keys.control: self._on_control,
                    self.keys.all_site_controls: self._on_control}  # a cloud's, per site
        if self._adapter is not None:
            handlers[self.keys.all_fresh] = self._on_fresh
        return handlers

    def liveliness(self) -> dict[str, TokenHandler]:
        """The liveliness tokens to watch: members and leaders."""
        return {self.keys.members: self._on_member, self.keys.leaders: self._on_leader}

    # --- logging on a channel ---

    def _log(self, topic: str, make: Callable[[str], Any], message: Any, at: float) -> None:
        with self._lock:
            channel = self._channels.get(topic)
            if channel is None:
                channel = self._channels[topic] = make(topic)
            self.counts[topic] += 1
        channel.log(message, log_time=_ns(at))

    def _json(self, schema: dict[str, Any]) -> Callable[[str], Channel]:
        return lambda topic: Channel(topic, schema=schema, context=self._context)

    def _note(self, level: LogLevel, text: str) -> None:
        now = self._clock()
        self._log(f"{self.root}/log", lambda t: LogChannel(t, context=self._context),
                  Log(timestamp=Timestamp.from_epoch_secs(now), level=level, message=text,
                      name=f"wiswarm/{self.keys.swarm}"), now)

    # --- the swarm's keys ---

    def _on_deliveries(self, key: str, data: Any) -> None:
        deliveries, bad = parse_deliveries(data)
        for follower, generated, delivered in deliveries:
            self._log(f"{self.root}/deliveries", self._json(schemas.DELIVERY), {
                "follower": follower, "outcome": "timeout" if generated is None else "delivered",
                "generated_at": generated, "delivered_at": delivered,
                "age_s": None if generated is None else delivered - generated}, delivered)
        for reason in bad:
            self.bad_input.report(key, reason)

    def _on_stats(self, key: str, data: Any) -> None:
        now = self._clock()
        if key == self.keys.leader_stats:
            record = parse_leader(data)
            self._log(f"{self.root}/leader/stats", self._json(schemas.LEADER_STATS), record, now)
            active = (record["leader"], record["epoch"])
            if active != self._active and record["leader"]:
                self._active = active
                self._note(LogLevel.Info, f"leader {active[0]} is active, epoch {active[1]}")
            return
        follower = self.keys.follower_of(key, "stats")
        if follower is None:
            raise ValueError("not a follower's stats key")
        self._log(f"{self.root}/{follower}/stats", self._json(schemas.FOLLOWER_STATS),
                  parse_stats(data, follower), now)

    def _on_tracking(self, key: str, data: Any) -> None:
        uav = self.keys.follower_of(key, TRACKING_LEAF)
        if uav is None:
            raise ValueError("not a UAV's tracking key")
        record, now = parse_tracking(data, uav), self._clock()
        self._log(f"{self.root}/{uav}/tracking", self._json(schemas.TRACKING), record, now)
        self._log(f"{self.root}/arena", lambda t: SceneUpdateChannel(t, context=self._context),
                  arena_update(record, now), now)

    def _on_control(self, key: str, sample: zenoh.Sample) -> None:
        control = decode_control(sample.payload.to_bytes())  # WireError: bad input
        self._log(f"{self.root}/control", self._json(schemas.CONTROL), {
            "seq": control.seq, "leader_time": control.leader_time, "epoch": control.epoch,
            "followers": [{"follower": follower, "waypoints": [list(w) for w in waypoints]}
                          for follower, waypoints in control.entries.items()]}, self._clock())

    def _on_fresh(self, key: str, sample: zenoh.Sample) -> None:
        follower = self.keys.follower_of(key, "fresh")
        attachment = sample.attachment
        if follower is None or attachment is None:
            raise ValueError("not a follower's fresh update, with its attachment")
        stamps = loads(attachment.to_bytes())
        generated = stamps.get("generated_at") if isinstance(stamps, dict) else None
        if isinstance(generated, bool) or not isinstance(generated, int | float):
            raise ValueError("the attachment has no generated_at")
        assert self._adapter is not None
        messages = self._adapter.messages(follower, sample.payload.to_bytes(), generated)
        for output, message in zip(self._adapter.outputs, messages, strict=True):
            if output.type_name == IMAGE:
                self._log(f"{self.root}/{follower}/image",
                          lambda t: CompressedImageChannel(t, context=self._context),
                          _png(message, generated), generated)
            elif output.type_name == POSE_STAMPED:
                self._log(f"{self.root}/{follower}/pose",
                          lambda t: PoseInFrameChannel(t, context=self._context),
                          _pose(message, generated), generated)

    def _on_member(self, key: str, joined: bool) -> None:
        follower = self.keys.follower_of(key, "members")
        if follower is None:
            raise ValueError("not a member's token")
        self._note(LogLevel.Info if joined else LogLevel.Warning,
                   f"follower {follower} {'joined' if joined else 'left'}")

    def _on_leader(self, key: str, started: bool) -> None:
        parts = key.split("/")
        if len(parts) != 5:
            raise ValueError("not a leader's token")
        self._note(LogLevel.Info if started else LogLevel.Warning,
                   f"leader {parts[3]} {'is up' if started else 'went'}")


def _png(image: Any, at: float) -> CompressedImage:
    """A ``sensor_msgs/msg/Image`` (mono8) as a lossless PNG."""
    import cv2  # only images need it, and only the tracking application's adapter makes them

    pixels = np.asarray(image.data, np.uint8).reshape(image.height, image.width)
    ok, png = cv2.imencode(".png", pixels)
    if not ok:
        raise ValueError("the image does not encode as PNG")
    return CompressedImage(timestamp=Timestamp.from_epoch_secs(at),
                           frame_id=image.header.frame_id, data=png.tobytes(), format="png")


def _pose(stamped: Any, at: float) -> PoseInFrame:
    position, orientation = stamped.pose.position, stamped.pose.orientation
    return PoseInFrame(timestamp=Timestamp.from_epoch_secs(at), frame_id=stamped.header.frame_id,
                       pose=Pose(position=Vector3(x=position.x, y=position.y, z=position.z),
                                 orientation=Quaternion(x=orientation.x, y=orientation.y,
                                                        z=orientation.z, w=orientation.w)))
