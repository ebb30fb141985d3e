"""``SwarmRecording`` into MCAP, read back by the independent ``mcap`` reader (and
``mcap-protobuf-support`` for the SDK's ``foxglove.*`` messages): every channel decodes,
and every delivery the leader made while recorded is in the file, once."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from apps.tracking.ros2 import FrameAdapter
from tests.transport.helpers import Samples, eventually, wait_until_known
from wiswarm_zenoh.recording import SwarmRecording
from wiswarm_zenoh.transport import SwarmKeys

from .conftest import SWARM, UAVS, Swarm

ROOT = f"/wiswarm/{SWARM}"
DELIVERIES = 100


def read(path: Path) -> tuple[dict[str, str], dict[str, list[Any]]]:
    """Each channel's schema name, and its messages decoded."""
    schemas: dict[str, str] = {}
    messages: dict[str, list[Any]] = {}
    with path.open("rb") as file:
        reader = make_reader(file, decoder_factories=[DecoderFactory()])
        for schema, channel, message in reader.iter_messages():
            assert schema is not None
            schemas[channel.topic] = schema.name
            if channel.message_encoding == "json":
                assert schema.encoding == "jsonschema" and json.loads(schema.data)["properties"]
                decoded: Any = json.loads(message.data)
            else:
                assert (channel.message_encoding, schema.encoding) == ("protobuf", "protobuf")
                decoded = DecoderFactory().decoder_for("protobuf", schema)(message.data)
            messages.setdefault(channel.topic, []).append(decoded)
    return schemas, messages


def records(batches: Samples) -> list[dict[str, Any]]:
    with batches.cond:
        return [r for sample in batches.samples for r in json.loads(sample.payload.to_bytes())]


def test_every_channel_decodes_and_no_delivery_is_missing(swarm: Swarm, tmp_path: Path) -> None:
    path, watcher = tmp_path / "run.mcap", swarm.node()
    recording = SwarmRecording(watcher, SWARM, mcap=path, adapter=FrameAdapter())
    batches = Samples(watcher, SwarmKeys(SWARM).leader_deliveries)  # what the recording hears
    try:
        wait_until_known(swarm.node(), SwarmKeys(SWARM).leader_deliveries)
        swarm.start()
        swarm.recorder.wait("deliveries", lambda r: len(r.deliveries) >= DELIVERIES)
        swarm.publish_tracking(watcher)
        swarm.publish_tracking(watcher, b"{not json")
        eventually("the bad tracking counted", lambda: recording.channels.bad_input.total() >= 1)
        eventually("a whole round of stats", lambda: recording.channels.counts[
            f"{ROOT}/leader/stats"] >= 1 and recording.channels.counts[f"{ROOT}/uav0/stats"] >= 1)
        swarm.stack.close()  # the leader flushes its last batch of deliveries as it goes
        last = swarm.recorder.deliveries[-1].delivered_at
        batches.wait("the leader's last batch", lambda b: any(
            record["delivered_at"] == last for record in records(b)))
        eventually("every batch recorded", lambda: recording.channels.counts[
            f"{ROOT}/deliveries"] == len(records(batches)))
    finally:
        recording.close()
    schemas, messages = read(path)
    assert {topic: schemas[topic] for topic in (
        f"{ROOT}/deliveries", f"{ROOT}/uav0/stats", f"{ROOT}/leader/stats", f"{ROOT}/control",
        f"{ROOT}/uav0/tracking", f"{ROOT}/arena", f"{ROOT}/log", f"{ROOT}/uav0/image",
        f"{ROOT}/uav1/pose")} == {
        f"{ROOT}/deliveries": "wiswarm.Delivery", f"{ROOT}/uav0/stats": "wiswarm.FollowerStats",
        f"{ROOT}/leader/stats": "wiswarm.LeaderStats", f"{ROOT}/control": "wiswarm.Control",
        f"{ROOT}/uav0/tracking": "wiswarm.Tracking", f"{ROOT}/arena": "foxglove.SceneUpdate",
        f"{ROOT}/log": "foxglove.Log", f"{ROOT}/uav0/image": "foxglove.CompressedImage",
        f"{ROOT}/uav1/pose": "foxglove.PoseInFrame"}

    recorded = [(m["follower"], m["generated_at"], m["delivered_at"])
                for m in messages[f"{ROOT}/deliveries"] if m["outcome"] == "delivered"]
    made = [(d.follower, d.generated_at, d.delivered_at) for d in swarm.recorder.deliveries]
    first = made.index(recorded[0])  # the stream starts once the leader knows of the recording
    assert Counter(recorded) == Counter(made[first:])
    assert len(recorded) >= DELIVERIES / 2

    image = messages[f"{ROOT}/uav0/image"][0]
    assert (image.format, image.frame_id) == ("png", "uav0/camera")
    assert image.data.startswith(b"\x89PNG")
    pose = messages[f"{ROOT}/uav1/pose"][0]
    assert (pose.frame_id, pose.pose.position.x, pose.pose.position.y) == ("world", 2.0, 2.0)
    scene = messages[f"{ROOT}/arena"][0]
    assert {entity.id for entity in scene.entities} == {"uav0", "uav0/car"}
    assert messages[f"{ROOT}/uav0/tracking"][0]["car_x"] == 1.0
    logs = [entry.message for entry in messages[f"{ROOT}/log"]]
    assert {f"follower {uav} joined" for uav in UAVS} <= set(logs)
    assert any(line.startswith("leader ") and "is active, epoch" in line for line in logs)
    assert messages[f"{ROOT}/control"][0]["followers"] is not None
    assert {m["follower"] for m in messages[f"{ROOT}/uav0/stats"]} == {"uav0"}
