"""The push baselines end to end on loopback, with real Zenoh sessions and sockets: every
system delivers stamped frames from two followers to its receiver, which measures them
and publishes the polling leader's stats; bad input is counted and logged with its
sender, never crashes the receiver, never lowers AoI."""

from __future__ import annotations

import csv
import logging
import multiprocessing
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh

from tests.baselines.helpers import FRAME, Clock, Frames
from tests.transport.helpers import WAIT, Samples, Sessions, eventually, wait_until_known
from wiswarm_zenoh.baselines import (
    BaselineFollowerOptions,
    FrameFifo,
    PushSender,
    Receiver,
    ReceiverOptions,
    TcpSender,
    UdpSender,
    run_baseline_followers,
    run_receiver,
)
from wiswarm_zenoh.baselines import fifo as fifo_module
from wiswarm_zenoh.baselines.stamp import LENGTH, STAMP, encode_frame, sender_id
from wiswarm_zenoh.baselines.tally import FollowerTally
from wiswarm_zenoh.core import AoITracker
from wiswarm_zenoh.programs.delivery_csv import DeliveryRecord
from wiswarm_zenoh.programs.demo import Children
from wiswarm_zenoh.programs.ticker import Ticker
from wiswarm_zenoh.transport.zenoh_config import SessionSpec, free_tcp_port

CONTRACT = {"follower", "aoi_s", "mean_aoi_s", "p95_aoi_s", "p_hat", "weight", "polls",
            "deliveries", "timeouts", "errors"}
LEADER_CONTRACT = {"followers", "polls_per_s", "mean_aoi_s", "policy", "uptime_s"}
Sender = PushSender | UdpSender | TcpSender


@pytest.fixture
def sessions() -> Iterator[Sessions]:
    opened = Sessions()
    yield opened
    opened.close_all()


def _senders(kind: str, sessions: Sessions, port: int, bind: str) -> list[Sender]:
    senders: list[Sender] = []
    for name in ("a", "b"):
        if kind == "push":
            session = sessions.node(port)
            senders.append(PushSender(session, "s1", name, clock=Clock()))
            wait_until_known(session, f"wiswarm/s1/{name}/push")
        else:
            kind_of = UdpSender if kind == "udp" else TcpSender
            senders.append(kind_of(name, bind, clock=Clock()))
    return senders


@pytest.mark.parametrize(("kind", "label"), [("push", "push-block"), ("udp", "udp"),
                                             ("tcp", "tcp")])
def test_two_followers_deliver_stamped_frames_measured_and_published(
        kind: str, label: str, sessions: Sessions, tmp_path: Path) -> None:
    port = free_tcp_port()
    sessions.router(port)
    # Stats only: a subscriber to the push keys would let a sender match before the
    # receiver does, and put its first frames to that one alone.
    watcher = Samples(sessions.node(port), "wiswarm/s1/*/stats")
    frames = Frames()
    bind = f"127.0.0.1:{free_tcp_port()}"
    record = DeliveryRecord(str(tmp_path / "record.csv"))
    with Receiver(sessions.node(port), "s1", kind, bind, on_frame=frames, record=record,
                  stats_period=0.1) as receiver:
        senders = _senders(kind, sessions, port, bind)
        started = time.time()
        for sender in senders:
            assert all(sender.offer(FRAME) for _ in range(5))
        frames.wait_for({"a", "b"}, 5)
        watcher.wait("stats of both", lambda s: all(
            s.stats(f"wiswarm/s1/{name}/stats") and
            s.stats(f"wiswarm/s1/{name}/stats")[-1]["deliveries"] == 5 for name in "ab"))
        # The leader's are put after the followers' and may still be on their way.
        watcher.wait("the leader's stats of both", lambda s: any(
            r["followers"] == ["a", "b"] for r in s.stats("wiswarm/s1/leader/stats")))
        for sender in senders:
            sender.close()
    record.close()
    for name in ("a", "b"):
        mine = frames.of(name)
        stamps = [generated_at for _, _, generated_at, _ in mine]
        assert stamps == sorted(stamps)
        assert all(started <= g <= now and payload == FRAME for _, payload, g, now in mine)
        stats = watcher.stats(f"wiswarm/s1/{name}/stats")[-1]
        assert set(stats) >= CONTRACT
        assert stats["p_hat"] == 1.0 and stats["lost"] == 0 and stats["errors"] == 0
        assert stats["throughput_mbps"] > 0 and stats["peak_aoi_s"] >= stats["aoi_s"]
    leader = watcher.stats("wiswarm/s1/leader/stats")[-1]
    assert set(leader) >= LEADER_CONTRACT
    assert leader["policy"] == label and leader["followers"] == ["a", "b"]
    assert leader["polls_per_s"] == 0.0 and receiver.summary.policy == label
    with (tmp_path / "record.csv").open(newline="") as src:
        rows = list(csv.reader(src))
    assert tuple(rows[0]) == DeliveryRecord.FIELDS and len(rows) == 11
    for name in ("a", "b"):  # the stamp's sequence numbers, in order
        assert [int(row[1]) for row in rows[1:] if row[0] == name] == [1, 2, 3, 4, 5]
        assert all(int(row[4]) == len(FRAME) and float(row[2]) <= float(row[3])
                   for row in rows[1:] if row[0] == name)


@pytest.mark.parametrize(("congestion", "control"), [
    ("block", zenoh.CongestionControl.BLOCK), ("drop", zenoh.CongestionControl.DROP)])
def test_drop_and_block_set_zenohs_congestion_control(
        congestion: str, control: zenoh.CongestionControl, sessions: Sessions) -> None:
    """The publisher's own property, and what the receiver sees on every sample (it names
    the system after it)."""
    port = free_tcp_port()
    sessions.router(port)
    watcher = Samples(sessions.node(port), "wiswarm/s1/leader/stats")
    frames = Frames()
    with Receiver(sessions.node(port), "s1", "push", on_frame=frames, stats_period=0.1):
        session = sessions.node(port)
        sender = PushSender(session, "s1", "a", congestion)
        assert sender.congestion_control == control
        wait_until_known(session, "wiswarm/s1/a/push")
        sender.offer(FRAME)
        frames.wait_for({"a"}, 1)
        watcher.wait("the system named", lambda s: any(
            r["policy"] == f"push-{congestion}" for r in s.stats("wiswarm/s1/leader/stats")))
        sender.close()
    with pytest.raises(ValueError, match="congestion"):
        PushSender(session, "s1", "x", congestion="later")


def test_a_full_fifo_drops_the_new_frame_and_keeps_the_sequence_of_frames_sent() -> None:
    """While the transport blocks on frame 1, two more fit; the rest are dropped at the
    tail without taking a sequence number: a gap at the receiver is a frame lost on the
    way, as an unanswered poll is."""
    sent: list[int] = []
    released, cond = threading.Event(), threading.Condition()

    def send(payload: bytes, generated_at: float, seq: int) -> None:
        with cond:
            sent.append(seq)
            cond.notify_all()
        released.wait(WAIT)

    queue = FrameFifo("x", send, capacity=2)
    assert queue.offer(b"f")
    with cond:
        assert cond.wait_for(lambda: sent == [1], WAIT)
    assert [queue.offer(b"f") for _ in range(5)] == [True, True, False, False, False]
    assert (queue.offered, queue.dropped) == (6, 3)
    released.set()
    with cond:
        assert cond.wait_for(lambda: len(sent) == 3, WAIT)
    assert queue.offer(b"f")
    with cond:
        assert cond.wait_for(lambda: len(sent) == 4, WAIT)
    assert sent == [1, 2, 3, 4]
    assert queue.close()


def test_close_drops_the_queue_and_does_not_wait_for_a_blocked_send(
        monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    monkeypatch.setattr(fifo_module, "CLOSE_WAIT", 0.05)
    caplog.set_level(logging.INFO, logger="wiswarm_zenoh")  # a stop's normal course
    sending, released = threading.Event(), threading.Event()
    sent: list[int] = []

    def send(payload: bytes, generated_at: float, seq: int) -> None:
        sending.set()
        released.wait(WAIT)
        sent.append(seq)

    queue = FrameFifo("x", send, capacity=4)
    assert queue.offer(b"f")
    assert sending.wait(WAIT)
    assert all(queue.offer(b"f") for _ in range(3))
    assert not queue.close()  # frame 1 is still being sent: left to end on its own
    assert "still blocked at close" in caplog.text
    released.set()
    assert queue.close()
    assert sent == [1]  # the three queued were dropped


class _BorrowedPublisher:
    """A Zenoh publisher as PyO3 holds it: ``put`` keeps the object borrowed while it
    blocks (BLOCK congestion on a full link), and ``undeclare`` from another thread in
    the meantime raises what zenoh-python raises, ``RuntimeError: Already borrowed``."""

    congestion_control = zenoh.CongestionControl.BLOCK

    def __init__(self) -> None:
        self.putting, self.unblock, self.undeclared = (threading.Event(), threading.Event(),
                                                       threading.Event())

    def put(self, payload: bytes, attachment: bytes) -> None:
        self.putting.set()
        self.unblock.wait(WAIT)
        self.putting.clear()

    def undeclare(self) -> None:
        if self.putting.is_set():
            raise RuntimeError("Already borrowed")
        self.undeclared.set()


def test_closing_a_push_sender_whose_put_blocks_never_undeclares_under_it(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The testbed study's teardown crash: close gave up waiting for a blocked put and
    undeclared the publisher from the closing thread. Now the sender's own thread
    undeclares it, once its put has returned."""
    monkeypatch.setattr(fifo_module, "CLOSE_WAIT", 0.05)
    publisher = _BorrowedPublisher()

    class Session:
        def declare_publisher(self, key: str, **options: object) -> _BorrowedPublisher:
            return publisher

    sender = PushSender(Session(), "s", "uav0")  # type: ignore[arg-type]
    assert sender.offer(FRAME)
    assert publisher.putting.wait(WAIT)
    sender.close()  # raised Already borrowed before
    assert not publisher.undeclared.is_set()
    publisher.unblock.set()  # the session closes: the put returns
    assert publisher.undeclared.wait(WAIT)
    assert sender.queue.close()


def test_sequence_spans_and_sender_restarts_give_p_hat() -> None:
    tally = FollowerTally(AoITracker(0.0))
    for seq in (1, 2, 4, 5):  # 3 lost on the way
        assert tally.take(seq * 0.01, seq, 10, seq * 0.01 + 0.001)
    assert not tally.take(0.005, 1, 10, 0.06)  # a duplicate, older than the freshest
    for seq in (1, 2):  # the sender started again: its sequence restarts, fresher frames
        assert tally.take(1.0 + seq * 0.01, seq, 10, 1.0 + seq * 0.01)
    stats = tally.stats("a", 0, 1.1)
    assert (tally.attempts, tally.extras(1.1)["received"], stats.stale) == (7, 7, 1)
    assert stats.p_hat == 1.0 and stats.deliveries == 6
    fresh = FollowerTally(AoITracker(0.0))
    for seq in (10, 14):
        fresh.take(seq * 0.01, seq, 10, seq * 0.01)
    assert fresh.stats("a", 0, 1.0).p_hat == pytest.approx(2 / 5)
    assert fresh.extras(1.0)["lost"] == 3


def test_malformed_datagrams_are_counted_and_logged_and_never_lower_aoi(
        sessions: Sessions, caplog: pytest.LogCaptureFixture) -> None:
    port = free_tcp_port()
    sessions.router(port)
    frames = Frames()
    udp_port = free_tcp_port()
    with Receiver(sessions.node(port), "s1", "udp", f"127.0.0.1:{udp_port}",
                  on_frame=frames) as receiver, \
            socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        to, name, now = ("127.0.0.1", udp_port), sender_id("a"), time.time()
        sock.sendto(encode_frame(name, now, 2, b"new"), to)
        frames.wait_for({"a"}, 1)
        for bad in (encode_frame(name, now + 3600, 3, b"from the future"), b"garbage",
                    encode_frame(name, now, 3, b"x")[:20],
                    encode_frame(name, float("nan"), 3, b"x"),
                    encode_frame(b"a/b", now, 3, b"x")):
            sock.sendto(bad, to)
        sock.sendto(encode_frame(name, now - 10.0, 1, b"old"), to)
        sock.sendto(encode_frame(name, now + 0.001, 4, b"newest"), to)
        frames.wait_for({"a"}, 2)
        receiver.publish_stats()
        record = receiver.latest[0]
    assert [f[1] for f in frames.frames] == [b"new", b"newest"]  # not the old one
    assert record["deliveries"] == 2 and record["stale"] == 1 and record["errors"] == 5
    assert float(record["aoi_s"]) < 5.0  # the old frame did not take the age back
    assert receiver.bad_input.total() == 5
    # Logged with the sender's address (one line a second per sender: the first here).
    assert "bad input from udp 127.0.0.1:" in caplog.text
    assert "ahead of the receiver's clock" in caplog.text


def test_bad_tcp_streams_are_dropped_and_counted_and_the_receiver_goes_on(
        sessions: Sessions) -> None:
    port = free_tcp_port()
    sessions.router(port)
    frames = Frames()
    bind = f"127.0.0.1:{free_tcp_port()}"
    to = ("127.0.0.1", int(bind.rsplit(":", 1)[1]))
    with Receiver(sessions.node(port), "s1", "tcp", bind, on_frame=frames) as receiver:
        with socket.create_connection(to) as rogue:
            rogue.sendall(LENGTH.pack(2**31) + b"x" * 100)
            assert rogue.recv(1) == b""  # closed by the receiver: no framing to trust
        with socket.create_connection(to) as odd:  # a bad frame in a sound stream
            good = encode_frame(sender_id("c"), time.time(), 1, b"ok")
            odd.sendall(LENGTH.pack(5) + b"hello" + LENGTH.pack(len(good)) + good)
            frames.wait_for({"c"}, 1)
        sender = TcpSender("b", bind, clock=Clock())
        assert all(sender.offer(FRAME) for _ in range(3))
        frames.wait_for({"b"}, 3)
        sender.close()
    assert receiver.bad_input.total() == 2


def test_push_samples_without_a_stamp_are_counted_to_their_follower(
        sessions: Sessions, caplog: pytest.LogCaptureFixture) -> None:
    port = free_tcp_port()
    sessions.router(port)
    frames = Frames()
    rogue = sessions.node(port)
    with Receiver(sessions.node(port), "s1", "push", on_frame=frames) as receiver:
        wait_until_known(rogue, "wiswarm/s1/a/push")
        rogue.put("wiswarm/s1/a/push", FRAME)
        rogue.put("wiswarm/s1/a/push", FRAME, attachment=b"short")
        rogue.put("wiswarm/s1/leader/push", FRAME, attachment=STAMP.pack(time.time(), 1))
        rogue.put("wiswarm/s1/a/push", b"fine", attachment=STAMP.pack(time.time(), 1))
        frames.wait_for({"a"}, 1)
        receiver.publish_stats()
    assert receiver.latest[0]["errors"] == 2 and receiver.bad_input.total() == 3
    assert "bad input from wiswarm/s1/a/push" in caplog.text
    assert "bad input from wiswarm/s1/leader/push" in caplog.text


def test_the_tcp_sender_reconnects_when_the_receiver_comes_back(
        sessions: Sessions, caplog: pytest.LogCaptureFixture) -> None:
    port = free_tcp_port()
    sessions.router(port)
    bind = f"127.0.0.1:{free_tcp_port()}"
    sender = TcpSender("a", bind)
    camera = Ticker(100.0, lambda now: sender.offer(FRAME), "camera")
    camera.start()
    try:
        for _ in range(2):  # the receiver goes away, then comes back on the same address
            frames = Frames()
            with Receiver(sessions.node(port), "s1", "tcp", bind, on_frame=frames):
                frames.wait_for({"a"}, 3)
    finally:
        camera.stop()
        sender.close()
    assert "connection to" in caplog.text or "cannot reach" in caplog.text


def test_runners_as_spawn_children_record_every_delivery(
        sessions: Sessions, tmp_path: Path) -> None:
    """``run_receiver`` and ``run_baseline_followers`` (two followers in one process, a
    session and socket each) as experiments start them: ``run_child`` in ``spawn``."""
    port = free_tcp_port()
    sessions.router(port)
    spec = SessionSpec.loopback("peer", connect_ports=[port])
    observer = sessions.node(port)
    watcher = Samples(observer, "wiswarm/s1/*/stats")
    bind, record = f"127.0.0.1:{free_tcp_port()}", tmp_path / "record.csv"
    with Children(multiprocessing.get_context("spawn")) as children:
        children.start("receiver", run_receiver, spec,
                       ReceiverOptions("s1", "udp", bind, str(record)))
        children.start("followers", run_baseline_followers, spec, BaselineFollowerOptions(
            "s1", ("u1", "u2"), "udp", 50.0, frame_bytes=20_000, receiver=bind))
        watcher.wait("both followers measured", lambda s: all(
            s.stats(f"wiswarm/s1/{name}/stats") and
            s.stats(f"wiswarm/s1/{name}/stats")[-1]["deliveries"] >= 10 for name in
            ("u1", "u2")))

        def members() -> list[str]:
            replies = observer.liveliness().get("wiswarm/s1/members/*")
            return sorted(str(r.ok.key_expr) for r in replies if r.ok is not None)

        # Tokens reach the observer's session on their own way through the router, not
        # with the stats: asked again until they are there (a busy machine delays them).
        eventually("both followers' tokens", lambda: members() == [
            "wiswarm/s1/members/u1", "wiswarm/s1/members/u2"])
    with record.open(newline="") as src:
        rows = list(csv.DictReader(src))
    assert tuple(rows[0]) == DeliveryRecord.FIELDS
    assert {row["follower"] for row in rows} == {"u1", "u2"}
    assert all(int(row["bytes"]) == 20_000 for row in rows)
