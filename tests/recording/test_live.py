"""``SwarmRecording`` served live: a WebSocket client speaking the Foxglove SDK's protocol
(``foxglove.sdk.v1``, written here from its specification: JSON ops, binary message
frames) sees the swarm's channels advertised, subscribes and decodes what comes."""

from __future__ import annotations

import base64
import json
import struct
import time
from typing import Any

from mcap.records import Schema
from mcap_protobuf.decoder import DecoderFactory
from websockets.sync.client import ClientConnection, connect

from wiswarm_apps.tracking.ros2 import FrameAdapter
from wiswarm_zenoh.recording import SwarmRecording

from .conftest import SWARM, Swarm

ROOT = f"/wiswarm/{SWARM}"
WANTED = (f"{ROOT}/deliveries", f"{ROOT}/uav0/image", f"{ROOT}/leader/stats")
WAIT_S = 15.0
MESSAGE_DATA = 1  # the binary opcode of a message on a subscribed channel


def advertised(socket: ClientConnection, topics: tuple[str, ...]) -> dict[str, dict[str, Any]]:
    """The channels advertised, by topic, until ``topics`` all are."""
    channels: dict[str, dict[str, Any]] = {}
    deadline = time.monotonic() + WAIT_S
    while not set(topics) <= set(channels):
        frame = socket.recv(timeout=max(0.0, deadline - time.monotonic()))
        if isinstance(frame, str):
            message = json.loads(frame)
            if message["op"] == "advertise":
                channels.update({channel["topic"]: channel for channel in message["channels"]})
    return channels


def test_a_websocket_client_subscribes_and_decodes(swarm: Swarm) -> None:
    recording = SwarmRecording(swarm.node(), SWARM, port=0, adapter=FrameAdapter())
    try:
        assert recording.url is not None
        with connect(recording.url, subprotocols=["foxglove.sdk.v1"]) as socket:  # type: ignore[list-item]
            swarm.start()
            channels = advertised(socket, WANTED)
            by_subscription = {index: channels[topic] for index, topic in enumerate(WANTED, 1)}
            socket.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": index, "channelId": channel["id"]}
                for index, channel in by_subscription.items()]}))
            got: dict[str, Any] = {}
            deadline = time.monotonic() + WAIT_S
            while len(got) < len(WANTED):
                frame = socket.recv(timeout=max(0.0, deadline - time.monotonic()))
                if isinstance(frame, bytes) and frame[0] == MESSAGE_DATA:
                    subscription, log_time = struct.unpack_from("<IQ", frame, 1)
                    channel = by_subscription[subscription]
                    got.setdefault(channel["topic"], (decode(channel, frame[13:]), log_time))
    finally:
        recording.close()
    image, _ = got[f"{ROOT}/uav0/image"]
    assert image.format == "png" and image.data.startswith(b"\x89PNG")
    delivery, log_time = got[f"{ROOT}/deliveries"]
    assert delivery["outcome"] in ("delivered", "timeout")
    assert abs(log_time / 1e9 - delivery["delivered_at"]) < 1e-6  # stamped with its time
    assert got[f"{ROOT}/leader/stats"][0]["policy"] == "whittle"


def decode(channel: dict[str, Any], data: bytes) -> Any:
    if channel["encoding"] == "json":
        return json.loads(data)
    schema = Schema(id=1, name=channel["schemaName"], encoding="protobuf",
                    data=base64.b64decode(channel["schema"]))
    return DecoderFactory().decoder_for("protobuf", schema)(data)
