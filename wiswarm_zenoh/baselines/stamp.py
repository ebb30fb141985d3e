"""What a pushed frame carries besides its bytes: its generation time and sequence number
(the ``<dQ`` attachment of a Zenoh put, DESIGN.md section 3), and, on plain sockets,
which follower sent it.

Socket frame: ``WSWP`` magic, version, follower id length, the ``<dQ`` stamp, the id,
then the frame. TCP prefixes each with its length. Decoders check every size and value
and raise ``WireError``: a receiver counts and logs it with the sender's address.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

from wiswarm_zenoh.core import WireError
from wiswarm_zenoh.transport.keys import check_follower

STAMP = struct.Struct("<dQ")  # generation time (sender's clock, s since the epoch), sequence
MAGIC = b"WSWP"
VERSION = 1
_HEAD = struct.Struct("<4sBB")  # magic, version, id length
HEADER_BYTES = _HEAD.size + STAMP.size  # plus the id
LENGTH = struct.Struct("<I")  # TCP: bytes of the socket frame that follows
MAX_UDP_PAYLOAD = 65507  # IPv4: 65535 - 20 (IP) - 8 (UDP)
MAX_FRAME_BYTES = 16 * 1024 * 1024  # a TCP length above this is garbage, not a frame


@dataclass(frozen=True, slots=True)
class Stamped:
    """A pushed frame as received."""

    follower: str
    generated_at: float
    seq: int
    payload: bytes


def decode_stamp(data: bytes) -> tuple[float, int]:
    """A Zenoh attachment's ``<dQ``; WireError if it is not one."""
    if len(data) != STAMP.size:
        raise WireError(f"stamp of {len(data)} bytes, expected {STAMP.size}")
    generated_at, seq = STAMP.unpack(data)
    if not math.isfinite(generated_at):
        raise WireError(f"generation time {generated_at!r} is not finite")
    return generated_at, seq


def encode_frame(follower: str, generated_at: float, seq: int, payload: bytes) -> bytes:
    """A socket frame (without TCP's length prefix)."""
    name = follower.encode()
    return _HEAD.pack(MAGIC, VERSION, len(name)) + STAMP.pack(generated_at, seq) + name + payload


def decode_frame(data: bytes) -> Stamped:
    """A socket frame; WireError names what is wrong."""
    if len(data) < HEADER_BYTES:
        raise WireError(f"frame of {len(data)} bytes is shorter than its header")
    magic, version, id_len = _HEAD.unpack_from(data)
    if magic != MAGIC or version != VERSION:
        raise WireError(f"not a push frame (magic {magic!r}, version {version})")
    generated_at, seq = decode_stamp(data[_HEAD.size:HEADER_BYTES])
    end = HEADER_BYTES + id_len
    if len(data) < end:
        raise WireError("frame ends inside the follower id")
    try:
        follower = check_follower(data[HEADER_BYTES:end].decode())
    except (UnicodeDecodeError, ValueError) as exc:
        raise WireError(f"bad follower id: {exc}") from None
    return Stamped(follower, generated_at, seq, data[end:])
