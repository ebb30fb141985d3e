"""Property tests (hypothesis): reassembly under loss, duplication and reordering; AoI
monotonicity and exact statistics; decoders raise nothing but WireError."""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable
from typing import Any

import msgpack
from hypothesis import given, settings
from hypothesis import strategies as st

from wiswarm_zenoh.core import (
    AoITracker,
    Delivered,
    Follower,
    FollowerConfig,
    Leader,
    LeaderConfig,
    Rejected,
    Stale,
    WireError,
)
from wiswarm_zenoh.core.config import FRAGMENT_HEADER_BYTES
from wiswarm_zenoh.core.fragments import OutgoingUpdate, Reassembler
from wiswarm_zenoh.core.queues import Update
from wiswarm_zenoh.core.wire import (
    Control,
    FragmentData,
    Poll,
    Reply,
    decode_control,
    decode_poll,
    decode_reply,
    encode_control,
    encode_poll,
    encode_reply,
)

from .drive import on_reply, on_timer, poll_when_due

PROPS = settings(max_examples=200, deadline=None, derandomize=True)  # same examples in CI
LATENCY = 0.001


@PROPS
@given(payload=st.binary(max_size=600), chunk=st.integers(1, 64), data=st.data())
def test_reassembly_under_loss_duplication_and_reordering(
    payload: bytes, chunk: int, data: st.DataObject
) -> None:
    out = OutgoingUpdate(Update(seq=3, generated_at=1.0, payload=payload), chunk=chunk)
    frags: list[FragmentData] = []
    while not out.done:
        frags.append(out.fragment())
        out.acknowledge(3, out.next_index)
    # arbitrary arrivals (lost ones missing, duplicates, any order), then the rest
    arrivals = data.draw(st.lists(st.sampled_from(frags), max_size=3 * len(frags)))
    missing = [f for f in frags if f not in arrivals]
    arrivals += data.draw(st.permutations(missing))
    r = Reassembler(max_fragments=len(frags), max_update_bytes=max(1, len(payload)))
    last_new = max(arrivals.index(f) for f in frags)  # the arrival that completes it
    results = [r.add(f) for f in arrivals[:last_new + 1]]
    assert results[-1] == payload
    assert all(res is None for res in results[:-1])


FATES = ["ok", "ok", "ok", "poll_lost", "reply_lost", "duplicate", "late", "garbage"]


@PROPS
@given(
    steps=st.lists(
        st.tuples(st.one_of(st.none(), st.binary(max_size=45)), st.sampled_from(FATES),
                  st.booleans()),
        max_size=40,
    ),
    garbage=st.binary(max_size=30),
)
def test_leader_and_follower_over_a_random_delivery_schedule(
    steps: list[tuple[bytes | None, str, bool]], garbage: bytes
) -> None:
    """Polls and replies lost, duplicated, or arriving late (after a later poll left), and
    garbage on the follower's key: every delivery is exactly an offered update, newer
    than the one before, and once the link heals the freshest update arrives."""
    cfg = FollowerConfig(fragment_size=FRAGMENT_HEADER_BYTES + 10, abandon_after=0.05)
    follower = Follower("a", cfg)
    leader = Leader(LeaderConfig(timeout=0.3))
    leader.add_follower("a", 0.0)
    offered: dict[int, tuple[float, bytes]] = {}
    delivered: list[Delivered] = []
    late: list[bytes] = []
    t = 0.0

    def consume(raw: bytes, now: float) -> None:
        delivered.extend(e for e in on_reply(leader, "a", raw, now) if isinstance(e, Delivered))

    for payload, fate, release_late in steps:
        t += 0.01
        if payload is not None and follower.offer(payload, t):
            offered[max(offered, default=0) + 1] = (t, payload)
        if late and release_late:  # an old reply turns up now: stale, or (the reply to
            # the last poll, which timed out) taken only as a measure of the link
            events = on_reply(leader, "a", late.pop(0), t)
            assert all(isinstance(e, Stale) for e in events)
        request = poll_when_due(leader, t)
        t = request.sent_at
        if fate == "poll_lost":
            t = request.deadline
            assert on_timer(leader, t)
            continue
        raw = follower.on_poll(request.payload, t + LATENCY, t + LATENCY)
        if fate in ("reply_lost", "late"):
            if fate == "late":
                late.append(raw)
            t = request.deadline
            assert on_timer(leader, t)
            continue
        if fate == "garbage":
            assert isinstance(on_reply(leader, "a", garbage, t + LATENCY)[0], Rejected)
        consume(raw, t + 2 * LATENCY)
        if fate == "duplicate":
            assert isinstance(on_reply(leader, "a", raw, t + 3 * LATENCY)[0], Stale)
        assert leader.in_flight is None

    for _ in range(20):  # the link heals: what is left (two updates at most) gets through
        t += 0.01
        request = poll_when_due(leader, t)
        t = request.sent_at
        consume(follower.on_poll(request.payload, t + LATENCY, t + LATENCY), t + 2 * LATENCY)

    stamps = [d.generated_at for d in delivered]
    assert stamps == sorted(set(stamps))  # strictly newer each time
    for d in delivered:  # exactly what was offered, on the leader's clock
        when, payload = offered[d.update_seq]
        assert d.payload == payload
        assert math.isclose(d.generated_at, when, abs_tol=1e-9)
    if offered:  # the freshest update always arrives in the end
        assert delivered[-1].update_seq == max(offered)
        assert math.isclose(leader.stats("a", t).aoi_s, t - delivered[-1].generated_at,
                            abs_tol=1e-9)


@PROPS
@given(st.lists(st.tuples(st.floats(0.0, 5.0), st.floats(0.0, 10.0)), max_size=30),
       st.floats(0.0, 1.0))
def test_aoi_drops_only_on_a_newer_time_stamp(
    moves: list[tuple[float, float]], q: float
) -> None:
    """Deliveries at increasing times of updates generated ``lag`` seconds earlier (any
    order of generation, after tracking began): the tracker agrees with a direct
    reconstruction of the sawtooth."""
    start = 1.0
    aoi = AoITracker(start)
    now, newest = start, start
    changes = [(start, start)]  # (time, tau from then on)
    for step, lag in moves:
        now += step
        timestamp = now - lag
        if timestamp <= start:  # generated before tracking began: a case of its own
            continue
        before = aoi.age(now)
        lowered = aoi.deliver(timestamp, now)
        assert lowered == (timestamp > newest)
        if lowered:
            newest = timestamp
            changes.append((now, newest))
            assert aoi.age(now) == now - timestamp < before or before == now - timestamp
        else:
            assert aoi.age(now) == before
    end = now + 1.0
    assert aoi.deliveries == len(changes) - 1
    # direct reconstruction of the sawtooth: (age at segment start, length)
    segments = [(t0 - tau, t1 - t0)
                for (t0, tau), (t1, _) in zip(changes, [*changes[1:], (end, 0.0)], strict=True)]
    area = sum(length * (a0 + length / 2) for a0, length in segments)
    assert math.isclose(aoi.mean(end), area / (end - start), rel_tol=1e-9, abs_tol=1e-9)
    assert math.isclose(aoi.peak(end), max(a0 + length for a0, length in segments),
                        rel_tol=1e-9)
    x = aoi.percentile(q, end)

    def time_below(age: float) -> float:
        return sum(min(max(age - a0, 0.0), length) for a0, length in segments)

    # exact to within one histogram bin (0.5 % of the age, 1e-5 s near zero)
    target = q * (end - start)
    assert time_below(x * 1.005 + 1e-5) >= target - 1e-9
    assert time_below(max(0.0, x / 1.005 - 1e-5)) <= target + 1e-9


DECODERS: list[Callable[[bytes], object]] = [decode_poll, decode_reply, decode_control]


def _raises_only_wire_error(data: bytes) -> None:
    for decode in DECODERS:
        with contextlib.suppress(WireError):
            decode(data)


@PROPS
@given(st.binary(max_size=300))
def test_decoders_raise_only_wire_error_on_arbitrary_bytes(data: bytes) -> None:
    _raises_only_wire_error(data)


MSGPACK_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**63), 2**64 - 1)
    | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=10)
    | st.binary(max_size=10),
    lambda inner: st.lists(inner, max_size=5) | st.dictionaries(st.text(max_size=5), inner,
                                                                max_size=5),
    max_leaves=20,
)
FIELD_NAMES = ["v", "t", "seq", "lt", "ack", "want", "from", "poll", "rt", "st", "frag",
               "entries", "u", "g", "i", "n", "size", "crc", "data"]
KINDS = ["poll", "reply", "control"]


def _pack(obj: object) -> bytes:
    packed: bytes = msgpack.packb(obj, use_bin_type=True)
    return packed


@PROPS
@given(st.dictionaries(st.sampled_from(FIELD_NAMES) | st.text(max_size=5), MSGPACK_VALUES,
                       max_size=10),
       st.sampled_from([*KINDS, None]), st.booleans())
def test_decoders_raise_only_wire_error_on_arbitrary_maps(
    fields: dict[str, Any], kind: str | None, versioned: bool
) -> None:
    if versioned:
        fields["v"] = 1
    if kind is not None:
        fields["t"] = kind
    _raises_only_wire_error(_pack(fields))


VALID = {
    "poll": encode_poll(Poll(4, 1.5, (2, 1), "next")),
    "reply": encode_reply(Reply("uav", 4, 2.0, 2.5, FragmentData(2, 1.0, 1, 3, 25, 7, b"x"))),
    "control": encode_control(Control(4, 1.5, {"uav": [(1.0, 2.0, 3.0, 4.0)], "b": []})),
}


@PROPS
@given(st.sampled_from(KINDS), st.data())
def test_decoders_raise_only_wire_error_on_mutated_valid_messages(
    kind: str, data: st.DataObject
) -> None:
    obj = msgpack.unpackb(VALID[kind])
    targets = [obj, *(v for v in obj.values() if isinstance(v, dict))]
    for target in data.draw(st.lists(st.sampled_from(targets), min_size=1, max_size=3)):
        key = data.draw(st.sampled_from(sorted(target)))
        target[key] = data.draw(MSGPACK_VALUES)
    _raises_only_wire_error(_pack(obj))


FINITE = st.floats(allow_nan=False, allow_infinity=False)
U63 = st.integers(0, 2**63 - 1)
U32 = st.integers(0, 2**32 - 1)
IDS = st.text(min_size=1, max_size=128)


@st.composite
def fragments(draw: st.DrawFn) -> FragmentData:
    count = draw(st.integers(1, 2**32 - 1))
    chunk = draw(st.binary(max_size=50))
    return FragmentData(draw(U63), draw(FINITE), draw(st.integers(0, count - 1)), count,
                        draw(st.integers(len(chunk), 2**40)), draw(U32), chunk)


@PROPS
@given(st.builds(Poll, U63, FINITE, st.none() | st.tuples(U63, U32),
                 st.sampled_from(["next", "fresh"])),
       st.builds(Reply, IDS, U63, FINITE, FINITE, st.none() | fragments()),
       st.builds(Control, U63, FINITE, st.dictionaries(
           IDS, st.lists(st.tuples(FINITE, FINITE, FINITE, FINITE), max_size=4), max_size=4)))
def test_valid_messages_round_trip(poll: Poll, reply: Reply, control: Control) -> None:
    assert decode_poll(encode_poll(poll)) == poll
    assert decode_reply(encode_reply(reply)) == reply
    back = decode_control(encode_control(control))
    assert (back.seq, back.leader_time, back.entries) == (
        control.seq, control.leader_time, {k: list(v) for k, v in control.entries.items()}
    )
