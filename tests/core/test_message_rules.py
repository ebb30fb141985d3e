"""Each message's rules are stated once (``messages``): the fast fixed-layout reader and
the strict general decoder refuse the same values, for the same reason, and accept the
same values up to each limit."""

from __future__ import annotations

import math
import re
from dataclasses import replace
from typing import Any

import msgpack
import pytest

from tests.core.build import pure_python_only
from wiswarm_zenoh.core import WireError, fixed_layout, messages, wire
from wiswarm_zenoh.core.fixed_layout import unpack_poll, unpack_reply
from wiswarm_zenoh.core.messages import (
    MAX_INT,
    MAX_SIZE,
    MAX_WAYPOINTS,
    UINT32,
    VERSION,
    Control,
    FragmentData,
    Poll,
    Reply,
    control_fault,
    poll_fault,
    reply_fault,
    waypoints_fault,
)
from wiswarm_zenoh.core.wire import (
    decode_control,
    decode_poll,
    decode_reply,
    encode_control,
    encode_poll,
    encode_reply,
    validate_waypoints,
)

FRAG = FragmentData(3, 0.5, 1, 2, 100, 7, b"abc")
TOO_BIG = MAX_INT + 1  # the layout's uint64 holds it, the protocol does not

# One field at a time given a value its wire type holds but the protocol forbids, with
# the wire key the fault must name.
BAD_POLLS: list[tuple[str, Poll]] = [
    ("seq", Poll(TOO_BIG, 1.0, None)),
    ("lt", Poll(1, math.nan, None)),
    ("lt", Poll(1, math.inf, (2, 0), "fresh")),
    ("lt", Poll(1, -math.inf, None)),
    ("ack[0]", Poll(1, 1.0, (TOO_BIG, 0), "fresh")),
    ("e", Poll(1, 1.0, None, "next", TOO_BIG)),
]
BAD_REPLIES: list[tuple[str, Reply]] = [
    ("poll", Reply("uav1", TOO_BIG, 0.0, 0.0, None)),
    ("rt", Reply("uav1", 1, math.nan, 0.0, FRAG)),
    ("st", Reply("uav1", 1, 0.0, math.inf, None)),
    ("frag.u", Reply("uav1", 1, 0.0, 0.0, replace(FRAG, update_seq=TOO_BIG))),
    ("frag.g", Reply("uav1", 1, 0.0, 0.0, replace(FRAG, generated_at=-math.inf))),
    ("frag.i", Reply("uav1", 1, 0.0, 0.0, replace(FRAG, index=2))),
    ("frag.i", Reply("uav1", 1, 0.0, 0.0, replace(FRAG, count=0, index=0))),
    ("frag.size", Reply("uav1", 1, 0.0, 0.0, replace(FRAG, total_size=2))),
    ("frag.size", Reply("uav1", 1, 0.0, 0.0, replace(FRAG, total_size=MAX_SIZE + 1))),
]
# Each value at its limit, which both readers accept.
EDGE_POLLS = [Poll(MAX_INT, -1e308, (MAX_INT, UINT32), "fresh", MAX_INT), Poll(0, 0.0, None)]
EDGE_REPLIES = [
    Reply("uav1", MAX_INT, 1e308, -1e308, FragmentData(MAX_INT, 0.0, UINT32 - 1, UINT32,
                                                       MAX_SIZE, UINT32, b"")),
    Reply("uav1", 0, 0.0, 0.0, replace(FRAG, index=0, count=1, total_size=3)),
]


def _general(message: Poll | Reply) -> bytes:
    """The same map as the fixed layout's, in another valid encoding: msgpack's shortest,
    keys in another order."""
    obj: dict[str, Any] = {"v": VERSION}
    if isinstance(message, Poll):
        obj |= {"t": "poll", "seq": message.seq, "lt": message.leader_time,
                "e": message.epoch, "want": message.want,
                "ack": None if message.ack is None else list(message.ack)}
    else:
        frag = message.fragment
        obj |= {"t": "reply", "from": message.follower, "poll": message.poll_seq,
                "rt": message.received_at, "st": message.sent_at, "frag": None if frag is None
                else {"u": frag.update_seq, "g": frag.generated_at, "i": frag.index,
                      "n": frag.count, "size": frag.total_size, "crc": frag.checksum,
                      "data": frag.data}}
    packed: bytes = msgpack.packb(dict(reversed(obj.items())), use_bin_type=True)
    return packed


@pytest.mark.parametrize(("key", "poll"), BAD_POLLS, ids=[k for k, _ in BAD_POLLS])
def test_a_bad_poll_is_refused_by_both_readers_for_the_same_reason(key: str,
                                                                   poll: Poll) -> None:
    fault = poll_fault(poll)
    assert fault is not None and f"'{key}'" in fault
    fixed, general = encode_poll(poll), _general(poll)
    assert fixed != general
    assert unpack_poll(fixed) is None
    for data in (fixed, general):
        with pytest.raises(WireError) as caught:
            decode_poll(data)
        assert str(caught.value) == fault


@pytest.mark.parametrize(("key", "reply"), BAD_REPLIES, ids=[k for k, _ in BAD_REPLIES])
def test_a_bad_reply_is_refused_by_both_readers_for_the_same_reason(key: str,
                                                                    reply: Reply) -> None:
    fault = reply_fault(reply)
    assert fault is not None and f"'{key}'" in fault
    fixed, general = encode_reply(reply), _general(reply)
    assert fixed != general
    assert unpack_reply(fixed) is None
    assert unpack_reply(fixed, reply.follower) is None
    for data, polled in ((fixed, None), (fixed, reply.follower), (general, None)):
        with pytest.raises(WireError) as caught:
            decode_reply(data, polled)
        assert str(caught.value) == fault


@pytest.mark.parametrize("poll", EDGE_POLLS)
def test_a_poll_at_the_limits_is_read_alike_by_both_readers(poll: Poll) -> None:
    assert poll_fault(poll) is None
    assert unpack_poll(encode_poll(poll)) == decode_poll(_general(poll)) == poll


@pytest.mark.parametrize("reply", EDGE_REPLIES)
def test_a_reply_at_the_limits_is_read_alike_by_both_readers(reply: Reply) -> None:
    assert reply_fault(reply) is None
    assert unpack_reply(encode_reply(reply)) == decode_reply(_general(reply)) == reply


@pure_python_only
def test_both_readers_call_the_one_checker(monkeypatch: pytest.MonkeyPatch) -> None:
    """Whatever the checker says goes, on either path (here: it refuses everything)."""
    poll, reply = EDGE_POLLS[0], EDGE_REPLIES[0]
    for module in (fixed_layout, wire):
        assert vars(module)["poll_fault"] is messages.poll_fault
        assert vars(module)["reply_fault"] is messages.reply_fault
        monkeypatch.setattr(module, "poll_fault", lambda _: "no poll today")
        monkeypatch.setattr(module, "reply_fault", lambda _: "no reply today")
    assert unpack_poll(encode_poll(poll)) is None
    assert unpack_reply(encode_reply(reply), reply.follower) is None
    for decode, data, said in ((decode_poll, encode_poll(poll), "no poll today"),
                               (decode_poll, _general(poll), "no poll today"),
                               (decode_reply, encode_reply(reply), "no reply today"),
                               (decode_reply, _general(reply), "no reply today")):
        with pytest.raises(WireError, match=said):
            decode(data)


CONTROL = Control(4, 100.0, {"uav1": [(1.0, 2.0, 3.0, 4.0)]}, 9)
BAD_CONTROLS: list[tuple[str, Control]] = [
    ("'seq'", replace(CONTROL, seq=TOO_BIG)),
    ("'lt'", replace(CONTROL, leader_time=math.nan)),
    ("'e'", replace(CONTROL, epoch=TOO_BIG)),
    ("key", replace(CONTROL, entries={"": []})),
    ("at most", replace(CONTROL, entries={"uav1": [(0.0, 0.0, 0.0, 0.0)] * 257})),
    ("4 finite", replace(CONTROL, entries={"uav1": [(0.0, 0.0, 0.0, math.inf)]})),
]


@pytest.mark.parametrize(("names", "control"), BAD_CONTROLS, ids=[n for n, _ in BAD_CONTROLS])
def test_bad_control_is_refused_for_what_its_checker_says(names: str,
                                                          control: Control) -> None:
    fault = control_fault(control)
    assert fault is not None and names in fault
    with pytest.raises(WireError) as caught:
        decode_control(encode_control(control))
    assert str(caught.value) == fault


@pytest.mark.parametrize("waypoints", [[(0.0, 0.0, 0.0, 0.0)] * (MAX_WAYPOINTS + 1),
                                       [(0.0, 0.0, 0.0)], [(1.0, 2.0, 3.0, math.nan)]])
def test_the_application_and_the_wire_share_the_waypoint_rule(waypoints: Any) -> None:
    fault = waypoints_fault(waypoints)
    assert fault is not None
    with pytest.raises(ValueError) as caught:
        validate_waypoints(waypoints)
    assert str(caught.value) == fault
    sent = {"v": VERSION, "t": "control", "seq": CONTROL.seq, "lt": CONTROL.leader_time,
            "e": CONTROL.epoch, "entries": {"uav1": [list(w) for w in waypoints]}}
    with pytest.raises(WireError, match=re.escape(fault)):  # as a rogue would send it
        decode_control(msgpack.packb(sent))
