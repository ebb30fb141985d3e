"""Property tests (hypothesis, 1000 examples each): genuine messages interleaved with
arbitrary rogue ones. The follower ends obeying its leader's latest control; the leader's
AoI for a follower is exactly the one its genuine replies give."""

from __future__ import annotations

from typing import Any

from hypothesis import example, given, settings
from hypothesis import strategies as st

from wiswarm_zenoh.core import Delivered, Follower, Leader, LeaderConfig, WireError
from wiswarm_zenoh.core.messages import MAX_INT
from wiswarm_zenoh.core.wire import (
    Control,
    FragmentData,
    Poll,
    Reply,
    checksum,
    decode_reply,
    encode_control,
    encode_poll,
    encode_reply,
)

from .drive import on_reply, on_timer, poll_when_due

ROGUE = settings(max_examples=1000, deadline=None, derandomize=True)  # same examples in CI
EPOCH = 1_700_000_000_000_000
WINDOW = 1.0  # FollowerConfig().control_window
finite = st.floats(-1e12, 1e12, allow_nan=False)
epochs = st.integers(0, MAX_INT)

rogue_control = st.one_of(
    st.tuples(st.just("future"), st.floats(0.001, 1e9)),
    st.tuples(st.just("past"), st.floats(0.001, 1e9)),
    st.tuples(st.just("replay"), st.integers(0, 1000)),
    st.tuples(st.just("huge_seq"), st.floats(0.001, WINDOW)),
    st.tuples(st.just("other_epoch"), epochs, finite, st.integers(0, MAX_INT)),
    st.tuples(st.just("other_ids"), epochs, finite),
    st.tuples(st.just("garbage"), st.binary(max_size=40)),
)
follower_step = st.one_of(
    st.tuples(st.just("wait"), st.floats(0.0, 3.0)),
    st.tuples(st.just("poll")),
    st.tuples(st.just("control")),
    st.tuples(st.just("rogue_poll"), st.one_of(st.just(EPOCH), epochs), finite),
    st.tuples(st.just("rogue_control"), rogue_control),
)


def _rogue_control_bytes(kind: tuple[Any, ...], leader_now: float, genuine: list[bytes],
                         last_lt: float | None) -> bytes:
    name = kind[0]
    entries = {"f": [(9.0, 9.0, 9.0, 9.0)]}
    if name == "future":
        return encode_control(Control(1, leader_now + WINDOW + kind[1], entries, EPOCH))
    if name == "past":
        return encode_control(Control(1, leader_now - WINDOW - kind[1], entries, EPOCH))
    if name == "replay" and genuine:
        return genuine[kind[1] % len(genuine)]
    if name == "huge_seq" and last_lt is not None:
        return encode_control(Control(MAX_INT, last_lt - kind[1], entries, EPOCH))
    if name == "other_epoch" and kind[1] != EPOCH:
        return encode_control(Control(kind[3], kind[2], entries, kind[1]))
    if name == "other_ids" and kind[1] != EPOCH:
        return encode_control(Control(1, kind[2], {"g": [(1.0, 1.0, 1.0, 1.0)]}, kind[1]))
    return kind[1] if name == "garbage" else b""


@ROGUE
@given(offset=st.floats(-1e5, 1e5), delay=st.floats(0.0, 0.05),
       steps=st.lists(follower_step, max_size=40))
def test_the_follower_ends_obeying_its_leaders_latest_control(
    offset: float, delay: float, steps: list[tuple[Any, ...]]
) -> None:
    """The leader's clock is ``offset`` ahead of the follower's, its messages take
    ``delay``. Every genuine control sent after a genuine poll (no forged poll of its
    epoch since) is obeyed, and after the rogue ones the leader's next poll and control
    always are."""
    follower = Follower("f")
    now, seq, obeyed = 0.0, 0, None
    genuine: list[bytes] = []
    last_lt: float | None = None
    clock_genuine = False  # the follower's view of the leader's clock comes from the leader

    def control(data: bytes) -> Any:
        nonlocal obeyed
        try:
            result = follower.on_control(data, now)
        except WireError:
            return "refused"
        if result is not None:
            obeyed = result
        return result

    for step in [*steps, ("wait", 0.01), ("poll",), ("control",)]:
        leader_now = now + offset
        if step[0] == "wait":
            now += step[1]
        elif step[0] == "poll":
            follower.on_poll(encode_poll(Poll(1, leader_now - delay, None, "next", EPOCH)),
                             now, now)
            clock_genuine = True
        elif step[0] == "rogue_poll":
            follower.on_poll(encode_poll(Poll(7, step[2], None, "fresh", step[1])), now, now)
            clock_genuine = clock_genuine and step[1] != EPOCH
        elif step[0] == "control":
            seq += 1
            last_lt = leader_now - delay
            waypoints = [(float(seq), 0.0, 0.0, 0.0)]
            data = encode_control(Control(seq, last_lt, {"f": waypoints}, EPOCH))
            genuine.append(data)
            result = control(data)
            if clock_genuine:
                assert result == waypoints, (step, result)
        else:
            control(_rogue_control_bytes(step[1], leader_now, genuine, last_lt))
    assert obeyed == [(float(seq), 0.0, 0.0, 0.0)]


# --- the leader ---

rogue_reply = st.one_of(
    st.tuples(st.just("future_stamp"), st.floats(0.006, 1e9)),
    st.tuples(st.just("forged_clock"), st.one_of(st.floats(0.5, 1e9), st.floats(-1e9, -0.5))),
    st.tuples(st.just("replay"), st.integers(0, 1000)),
    st.tuples(st.just("other_id")),
    st.tuples(st.just("huge_seq"), st.booleans()),
    st.tuples(st.just("garbage"), st.binary(max_size=60)),
)
cycle = st.tuples(
    st.booleans(),  # the follower has a new update
    st.lists(rogue_reply, max_size=3),  # before its answer
    st.integers(0, 3),  # 0: the answer is lost (at most 2 in a row), else it arrives
    st.lists(rogue_reply, max_size=2),  # after it
)


def _forge(kind: tuple[Any, ...], poll_seq: int, genuine_reply: Reply, replies: list[bytes],
           answered_once: bool) -> bytes | None:
    """A rogue reply to the poll in flight, built from what a stranger can see (the poll
    and, in an open swarm, the follower's own replies)."""
    name, rt, st_ = kind[0], genuine_reply.received_at, genuine_reply.sent_at
    frag = FragmentData(MAX_INT, rt, 0, 1, 5, checksum(b"rogue"), b"rogue")
    if name == "future_stamp":
        frag.generated_at = st_ + kind[1]
        return encode_reply(Reply("f", poll_seq, rt, st_, frag))
    if name == "forged_clock" and answered_once:  # the first answer anchors the clock
        frag.generated_at = rt + kind[1]
        return encode_reply(Reply("f", poll_seq, rt + kind[1], st_ + kind[1], frag))
    if name == "replay" and replies:
        return replies[kind[1] % len(replies)]
    if name == "other_id":
        return encode_reply(Reply("g", poll_seq, rt, st_, frag))
    if name == "huge_seq":
        return encode_reply(Reply("f", MAX_INT if kind[1] else poll_seq + 10**9, rt, st_, frag))
    return kind[1] if name == "garbage" else None


FORGED = ("forged_clock", 1.0)
QUIET = (False, [], 0, [])  # answered or lost, nothing rogue


@ROGUE
@given(offset=st.floats(-1e5, 1e5), cycles=st.lists(cycle, min_size=1, max_size=25))
# Found by hypothesis: two forgeries in one poll after two refused polls (the second must
# not count as a third refused poll), and the follower's own reply after them (it must
# not re-anchor the clock estimate: it agrees with it).
@example(offset=0.0, cycles=[QUIET] * 3 + [(False, [FORGED], 0, [])] * 2
         + [(False, [FORGED, FORGED], 0, [])])
@example(offset=1.0, cycles=[QUIET] * 3 + [(False, [FORGED], 0, [])] * 2
         + [(True, [FORGED], 0, [])])
def test_the_leaders_aoi_is_the_one_its_followers_genuine_updates_give(
    offset: float, cycles: list[tuple[Any, ...]]
) -> None:
    """Two leaders poll at the same times: one gets only the follower's replies, the other
    the same replies with rogue ones before and after. Nothing rogue changes a poll, a
    delivery or a statistic: the polls they send are the same bytes throughout."""
    config = LeaderConfig(clock_samples=4)
    subject, reference = Leader(config, epoch=EPOCH), Leader(config, epoch=EPOCH)
    for leader in (subject, reference):
        leader.add_follower("f", 0.0)
    follower = Follower("f")
    now, lost_in_a_row, answered_once = 1.0, 0, False
    replies: list[bytes] = []
    for new_update, before, arrives, after in cycles:
        if new_update:
            follower.offer(b"frame %.6f" % now, now + offset - 0.0005)
        request = poll_when_due(subject, now)
        now = request.sent_at  # later, if no source was due yet: the same for both
        twin = reference.next_poll(now)
        assert twin is not None and request.payload == twin.payload
        at = now + 0.001 + offset
        raw = follower.on_poll(request.payload, at, at + 0.0001)
        genuine = decode_reply(raw)
        for kind in before:
            forged = _forge(kind, request.poll_seq, genuine, replies, answered_once)
            if forged is not None:
                assert not [e for e in on_reply(subject, "f", forged, now + 0.0015)
                            if isinstance(e, Delivered)]
        lost = arrives == 0 and lost_in_a_row < 2  # fewer than clock_samples - 1
        lost_in_a_row = lost_in_a_row + 1 if lost else 0
        if lost:
            events = [on_timer(subject, now + 0.3), on_timer(reference, now + 0.3)]
        else:
            events = [on_reply(subject, "f", raw, now + 0.002),
                      on_reply(reference, "f", raw, now + 0.002)]
            answered_once = True
        assert events[0] == events[1]
        replies.append(raw)
        for kind in after:
            forged = _forge(kind, request.poll_seq, genuine, replies, answered_once)
            if forged is not None:
                assert not [e for e in on_reply(subject, "f", forged, now + 0.003)
                            if isinstance(e, Delivered)]
        now += 0.5
    mine, theirs = subject.stats("f", now), reference.stats("f", now)
    for field in ("aoi_s", "mean_aoi_s", "peak_aoi_s", "p_hat", "deliveries", "polls",
                  "timeouts", "clock_offset_s"):
        assert getattr(mine, field) == getattr(theirs, field), field
