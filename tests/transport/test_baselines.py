"""The push baselines end to end on loopback: every system delivers stamped frames from
two followers to its receiver, which measures them and publishes the polling leader's
stats; bad input is counted and logged, never crashes, never lowers AoI."""

from __future__ import annotations

import socket
import threading
import time
from pathlib import Path

import pytest

from wiswarm_zenoh.baselines import PushSender, Receiver, TcpSender, UdpSender
from wiswarm_zenoh.baselines.senders import CONGESTION, FrameFifo
from wiswarm_zenoh.baselines.stamp import LENGTH, Stamped, encode_frame
from wiswarm_zenoh.transport.runners import DeliveryRecord
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

from .helpers import WAIT, Samples, Sessions, wait_until_known

FRAME = bytes(5000)


class Frames:
    """What the receiver handed on, waitable."""

    def __init__(self) -> None:
        self.frames: list[Stamped] = []
        self.cond = threading.Condition()

    def __call__(self, frame: Stamped, now: float) -> None:
        with self.cond:
            self.frames.append(frame)
            self.cond.notify_all()

    def wait_for(self, followers: set[str], each: int) -> None:
        with self.cond:
            assert self.cond.wait_for(lambda: all(
                sum(f.follower == name for f in self.frames) >= each for name in followers),
                WAIT), f"fewer than {each} frames from each of {followers}"


def _sent_frames(sender: PushSender | UdpSender | TcpSender, count: int) -> None:
    for _ in range(count):
        assert sender.offer(FRAME)


@pytest.mark.parametrize("kind", ["push", "udp", "tcp"])
def test_two_followers_deliver_stamped_frames_and_stats(
        kind: str, sessions: Sessions, tmp_path: Path) -> None:
    port = free_tcp_port()
    sessions.router(port)
    leader = sessions.node(port)
    watcher = Samples(sessions.node(port), "wiswarm/s1/**")
    frames = Frames()
    bind = f"127.0.0.1:{free_tcp_port()}"
    record = DeliveryRecord(str(tmp_path / "record.csv"))

    def on_frame(frame: Stamped, now: float) -> None:
        record.row(frame.follower, frame.seq, frame.generated_at, now, len(frame.payload))
        frames(frame, now)

    with Receiver(leader, "s1", kind, bind, on_frame=on_frame, stats_period=0.1) as receiver:
        senders: list[PushSender | UdpSender | TcpSender] = []
        for name in ("a", "b"):
            if kind == "push":
                session = sessions.node(port)
                senders.append(PushSender(session, "s1", name))
                wait_until_known(session, f"wiswarm/s1/{name}/push")
            elif kind == "udp":
                senders.append(UdpSender(name, bind))
            else:
                senders.append(TcpSender(name, bind))
        started = time.time()
        for sender in senders:
            _sent_frames(sender, 5)
        frames.wait_for({"a", "b"}, 5)
        watcher.wait("stats of both", lambda s: bool(s.stats("wiswarm/s1/a/stats"))
                     and bool(s.stats("wiswarm/s1/b/stats")))
        for sender in senders:
            sender.close()
    record.close()
    for name in ("a", "b"):
        mine = [f for f in frames.frames if f.follower == name]
        assert [f.seq for f in mine] == [1, 2, 3, 4, 5]
        assert all(started <= f.generated_at <= time.time() and f.payload == FRAME
                   for f in mine)
        stats = watcher.stats(f"wiswarm/s1/{name}/stats")[-1]
        assert {"follower", "aoi_s", "mean_aoi_s", "p95_aoi_s", "p_hat", "weight", "polls",
                "deliveries", "timeouts", "errors"} <= set(stats)
        assert stats["deliveries"] == 5 and stats["p_hat"] == 1.0
    leader_stats = watcher.stats("wiswarm/s1/leader/stats")[-1]
    assert leader_stats["policy"] == kind and sorted(leader_stats["followers"]) == ["a", "b"]
    assert receiver.latest
    lines = (tmp_path / "record.csv").read_text().splitlines()
    assert lines[0] == ",".join(DeliveryRecord.FIELDS) and len(lines) == 11


def test_block_and_drop_set_zenohs_congestion_control(sessions: Sessions) -> None:
    session = sessions.node(free_tcp_port())
    for name, expected in CONGESTION.items():
        sender = PushSender(session, "s1", f"f{name}", congestion=name)
        assert sender._publisher.congestion_control == expected
        sender.close()
    with pytest.raises(ValueError, match="congestion"):
        PushSender(session, "s1", "x", congestion="later")


def test_a_full_fifo_drops_the_newest_frame_and_close_does_not_wait_for_the_queue() -> None:
    """While the transport blocks on frame 1, two more fit in the FIFO and the rest are
    dropped at the tail; closing lets frame 1 finish and drops what is still queued."""
    sending, release = threading.Event(), threading.Event()
    sent: list[int] = []

    def send(payload: bytes, generated_at: float, seq: int) -> None:
        sending.set()
        release.wait(WAIT)
        sent.append(seq)

    fifo = FrameFifo("x", send, capacity=2)
    assert fifo.offer(b"f")
    assert sending.wait(WAIT)
    assert [fifo.offer(b"f") for _ in range(5)] == [True, True, False, False, False]
    assert fifo.dropped == 3
    release.set()
    fifo.close()
    assert sent == [1]


def test_bad_input_is_counted_and_never_lowers_aoi(
        sessions: Sessions, caplog: pytest.LogCaptureFixture) -> None:
    port = free_tcp_port()
    sessions.router(port)
    leader = sessions.node(port)
    frames = Frames()
    bind = f"127.0.0.1:{free_tcp_port()}"
    with Receiver(leader, "s1", "udp", bind, on_frame=frames) as receiver:
        host, udp_port = bind.split(":")
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            now = time.time()
            sock.sendto(encode_frame("a", now, 2, b"new"), (host, int(udp_port)))
            frames.wait_for({"a"}, 1)
            sock.sendto(b"garbage", (host, int(udp_port)))
            sock.sendto(encode_frame("a", float("nan"), 3, b"x")[:40], (host, int(udp_port)))
            sock.sendto(encode_frame("a", now - 10.0, 1, b"old"), (host, int(udp_port)))
            sock.sendto(encode_frame("a", now + 0.001, 4, b"newest"), (host, int(udp_port)))
            frames.wait_for({"a"}, 2)
        receiver.publish_stats()
        record = receiver.latest[0]
    assert [f.payload for f in frames.frames] == [b"new", b"newest"]  # the old one: no
    assert record["deliveries"] == 2 and receiver.bad_input.total() == 2
    assert "bad input from udp 127.0.0.1:" in caplog.text


def test_a_tcp_stream_of_garbage_is_dropped_and_the_receiver_goes_on(sessions: Sessions) -> None:
    port = free_tcp_port()
    sessions.router(port)
    frames = Frames()
    bind = f"127.0.0.1:{free_tcp_port()}"
    host, tcp_port = bind.split(":")
    with Receiver(sessions.node(port), "s1", "tcp", bind, on_frame=frames) as receiver:
        with socket.create_connection((host, int(tcp_port))) as rogue:
            rogue.sendall(LENGTH.pack(2**31) + b"x" * 100)
            assert rogue.recv(1) == b""  # closed by the receiver
        sender = TcpSender("b", bind)
        _sent_frames(sender, 3)
        frames.wait_for({"b"}, 3)
        sender.close()
    assert receiver.bad_input.total() == 1
