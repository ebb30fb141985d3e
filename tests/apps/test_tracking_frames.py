"""Frame messages: exact round trip; anything malformed raises FrameError with a reason."""

from __future__ import annotations

import contextlib
import math
from typing import Any

import msgpack
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wiswarm_apps.tracking.frames import Frame, FrameError, decode_frame, encode_frame
from wiswarm_apps.tracking.geometry import CameraModel, Pose

CAMERA = CameraModel(width=160, height=160)


def sample_frame() -> Frame:
    pixels = np.random.default_rng(1).integers(0, 256, (160, 160), dtype=np.uint8)
    return Frame(t=12.5, pose=Pose(1.0, 2.0, 2.5, -0.3), camera=CAMERA, pixels=pixels)


def fields() -> dict[str, Any]:
    decoded = msgpack.unpackb(encode_frame(sample_frame()), raw=False)
    assert isinstance(decoded, dict)
    return decoded


def test_round_trip_is_exact_and_sized() -> None:
    frame = sample_frame()
    data = encode_frame(frame)
    assert 160 * 160 < len(data) < 160 * 160 + 100
    back = decode_frame(data, expected=CAMERA)
    assert (back.t, back.pose, back.camera) == (frame.t, frame.pose, frame.camera)
    np.testing.assert_array_equal(back.pixels, frame.pixels)


def test_224_frame_is_50176_pixel_bytes() -> None:
    camera = CameraModel()
    frame = Frame(0.0, Pose(1, 1, 2), camera, np.zeros((224, 224), np.uint8))
    assert len(decode_frame(encode_frame(frame)).pixels.tobytes()) == 50_176


def reencode(**changes: Any) -> bytes:
    message = fields()
    for key, value in changes.items():
        if value is None:
            del message[key]
        else:
            message[key] = value
    return bytes(msgpack.packb(message, use_bin_type=True))


@pytest.mark.parametrize(
    ("data", "reason"),
    [
        (b"\xc1garbage", "undecodable"),
        (b"", "undecodable"),
        (msgpack.packb([1, 2, 3]), "map"),
        (reencode(px=b"\x00" * 100), "px must be 25600 bytes"),
        (reencode(px="text"), "px must be"),
        (reencode(w=161), "px must be 25760 bytes"),
        (reencode(w=3), "width"),
        (reencode(pose=[1.0, 2.0, math.nan, 0.0]), "finite"),
        (reencode(pose=[1.0, 2.0, -1.0, 0.0]), "altitude"),
        (reencode(pose=[1.0, 2.0]), "pose"),
        (reencode(t=True), "number"),
        (reencode(fov=400.0), "fov"),
        (reencode(v=2), "version"),
        (reencode(extra=1), "keys"),
        (reencode(t=None), "keys"),
    ],
)
def test_bad_frames_raise_frame_error_with_reason(data: bytes, reason: str) -> None:
    with pytest.raises(FrameError, match=reason):
        decode_frame(data)


def test_frame_of_another_camera_is_rejected_when_one_is_expected() -> None:
    with pytest.raises(FrameError, match="expected"):
        decode_frame(encode_frame(sample_frame()), expected=CameraModel())


def test_encoder_refuses_pixels_that_do_not_match_the_camera() -> None:
    frame = Frame(0.0, Pose(1, 1, 2), CAMERA, np.zeros((10, 10), np.uint8))
    with pytest.raises(ValueError, match="shape"):
        encode_frame(frame)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=300))
def test_random_bytes_only_ever_raise_frame_error(data: bytes) -> None:
    with pytest.raises(FrameError):
        decode_frame(data)


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 25_700), st.integers(0, 255))
def test_corrupting_one_byte_never_escapes_as_another_error(index: int, value: int) -> None:
    data = bytearray(encode_frame(sample_frame()))
    data[index % len(data)] = value
    with contextlib.suppress(FrameError):
        decode_frame(bytes(data))
