"""What a pushed frame carries besides its bytes, in one place for senders and receivers:
its generation time and sequence number (the ``<dQ`` attachment of a Zenoh put on
``wiswarm/<swarm>/<follower>/push``, DESIGN.md section 3) and, on plain sockets, which
follower sent it.

Socket frame: ``WSWP`` magic, version, follower id length, the ``<dQ`` stamp, the id,
then the frame. TCP prefixes each with its length (``<I``). Decoders check every size
and value and raise ``WireError``: a receiver counts and logs it with the sender's
address and carries on.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

from wiswarm_zenoh.core import WireError
from wiswarm_zenoh.core.config import DEFAULT_MAX_UPDATE_BYTES
from wiswarm_zenoh.transport.keys import SwarmKeys, check_follower

PUSH_LEAF = "push"
STAMP = struct.Struct("<dQ")  # generation time (sender's clock, s since the epoch), sequence
MAGIC = b"WSWP"
VERSION = 1
_HEAD = struct.Struct("<4sBB")  # magic, version, id length
HEADER_BYTES = _HEAD.size + STAMP.size  # plus the id
MAX_ID_BYTES = 255  # the id length is one byte
LENGTH = struct.Struct("<I")  # TCP: bytes of the socket frame that follows
MAX_UDP_PAYLOAD = 65507  # IPv4: 65535 - 20 (IP header) - 8 (UDP header)
MAX_FRAME_BYTES = DEFAULT_MAX_UPDATE_BYTES  # the largest frame, as the largest polled update
MAX_TCP_LENGTH = HEADER_BYTES + MAX_ID_BYTES + MAX_FRAME_BYTES  # beyond: garbage, not a frame


@dataclass(frozen=True, slots=True)
class Stamped:
    """A pushed frame as received."""

    follower: str
    generated_at: float
    seq: int
    payload: bytes


def push_key(keys: SwarmKeys, follower: str) -> str:
    return f"{keys.prefix}/{check_follower(follower)}/{PUSH_LEAF}"


def sender_id(follower: str) -> bytes:
    """A follower id as socket frames carry it; ValueError if it cannot be one."""
    name = check_follower(follower).encode()
    if len(name) > MAX_ID_BYTES:
        raise ValueError(f"follower id {follower!r} is over {MAX_ID_BYTES} bytes")
    return name


def udp_frame_limit(follower: str) -> int:
    """The largest frame that fits one UDP datagram with this follower's header."""
    return MAX_UDP_PAYLOAD - HEADER_BYTES - len(sender_id(follower))


def decode_stamp(data: bytes) -> tuple[float, int]:
    """A Zenoh attachment's ``<dQ``; WireError if it is not one."""
    if len(data) != STAMP.size:
        raise WireError(f"stamp of {len(data)} bytes, expected {STAMP.size}")
    generated_at, seq = STAMP.unpack(data)
    if not math.isfinite(generated_at):
        raise WireError(f"generation time {generated_at!r} is not finite")
    return generated_at, seq


def encode_frame(name: bytes, generated_at: float, seq: int, payload: bytes) -> bytes:
    """A socket frame (without TCP's length prefix); ``name`` from ``sender_id``."""
    return b"".join((_HEAD.pack(MAGIC, VERSION, len(name)), STAMP.pack(generated_at, seq),
                     name, payload))


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


def parse_address(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (``[v6]:PORT`` too) -> (host, port); ValueError says what is wrong."""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"address {text!r} must look like HOST:PORT")
    return host.removeprefix("[").removesuffix("]"), int(port)
