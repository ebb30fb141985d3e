"""``SwarmRecording`` served live: a WebSocket client speaking the Foxglove SDK's protocol
(``foxglove.sdk.v1``, written here from its specification: JSON ops, binary message
frames) sees the swarm's channels advertised, subscribes and decodes what comes."""

from __future__ import annotations

import base64
import itertools
import json
import re
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
UNKNOWN_CHANNEL = re.compile(r"Unknown channel ID: (\d+)")  # a subscription refused


def first_messages(socket: ClientConnection, topics: tuple[str, ...]
                   ) -> dict[str, tuple[dict[str, Any], bytes, int]]:
    """The first message of each of ``topics``: (its channel, its data, its log time).
    As the protocol has it, channels come (advertise) and go (unadvertise), and a
    subscription to one gone meanwhile is refused: each topic is subscribed on the
    channel last advertised for it, again on a newer one, until a message of it came.
    The SDK also refuses, now and then, a channel it has just advertised (its record of
    what this client was told lags the message on a busy machine: "Unknown channel
    ID: 28"): such a one is subscribed again."""
    channels: dict[str, dict[str, Any]] = {}  # the topic's channel last advertised
    subscribed: dict[int, dict[str, Any]] = {}  # by subscription id
    ids = itertools.count(1)
    got: dict[str, tuple[dict[str, Any], bytes, int]] = {}
    deadline = time.monotonic() + WAIT_S
    while len(got) < len(topics):
        frame = socket.recv(timeout=max(0.0, deadline - time.monotonic()))
        if isinstance(frame, bytes) and frame[0] == MESSAGE_DATA:
            subscription, log_time = struct.unpack_from("<IQ", frame, 1)
            channel = subscribed[subscription]
            got.setdefault(channel["topic"], (channel, frame[13:], log_time))
        elif isinstance(frame, str):
            message = json.loads(frame)
            if message["op"] == "advertise":
                channels.update({c["topic"]: c for c in message["channels"]
                                 if c["topic"] in topics})
            elif message["op"] == "unadvertise":
                gone = set(message["channelIds"])
                channels = {t: c for t, c in channels.items() if c["id"] not in gone}
            elif message["op"] == "status" and \
                    (refused := UNKNOWN_CHANNEL.fullmatch(message["message"])):
                subscribed = {i: c for i, c in subscribed.items() if c["id"] != int(refused[1])}
            fresh = {next(ids): c for t, c in channels.items()
                     if t not in got and c not in subscribed.values()}
            if fresh:
                subscribed.update(fresh)
                socket.send(json.dumps({"op": "subscribe", "subscriptions": [
                    {"id": index, "channelId": c["id"]} for index, c in fresh.items()]}))
    return got


def test_a_websocket_client_subscribes_and_decodes(swarm: Swarm) -> None:
    recording = SwarmRecording(swarm.node(), SWARM, port=0, adapter=FrameAdapter())
    try:
        assert recording.url is not None
        with connect(recording.url, subprotocols=["foxglove.sdk.v1"]) as socket:  # type: ignore[list-item]
            swarm.start()
            got = {topic: (decode(channel, data), log_time)
                   for topic, (channel, data, log_time) in first_messages(socket, WANTED).items()}
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
