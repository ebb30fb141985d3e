"""Newest-only push: the slot of one (a newer frame replaces the one waiting, an older
one never does, counted), the thread that sends from it, and its Zenoh and TCP senders
delivering to the receivers the FIFO baselines use (same wire, same keys)."""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator

import pytest
import zenoh

from tests.baselines.helpers import FRAME, Clock, Frames
from tests.transport.helpers import WAIT, Samples, Sessions, wait_until_known
from wiswarm_zenoh.baselines import (
    NEWEST_ZENOH,
    BaselineFollowerOptions,
    NewestPump,
    NewestSlot,
    PushSender,
    Receiver,
    TcpSender,
)
from wiswarm_zenoh.baselines.runners import follower_session_spec
from wiswarm_zenoh.transport.zenoh_config import SessionSpec, free_tcp_port


@pytest.fixture
def sessions() -> Iterator[Sessions]:
    opened = Sessions()
    yield opened
    opened.close_all()


def test_a_newer_frame_replaces_the_one_waiting_and_an_older_one_never_does() -> None:
    slot: NewestSlot[str] = NewestSlot()
    assert slot.take() is None
    assert slot.offer("a", 1.0) and slot.offer("b", 2.0)  # b replaces a
    assert not slot.offer("old", 1.5)  # older than b: refused, b still waits
    assert slot.take() == ("b", 2.0, 1)
    assert not slot.waiting and slot.take() is None
    assert not slot.offer("older than the one sent", 1.9)
    assert slot.offer("c", 3.0) and slot.offer("d", 3.0)  # as new: the later one
    assert slot.take() == ("d", 3.0, 2)  # numbered as sent: a gap is a frame lost
    assert (slot.offered, slot.replaced, slot.refused, slot.sent) == (6, 2, 2, 2)


def test_a_source_stamp_one_nanosecond_older_is_refused() -> None:
    """An epoch time in ns is 238 ns coarse as seconds in a float: by the float alone the
    older sample looked as new and replaced the one waiting (a ROS 2 source's)."""
    slot: NewestSlot[str] = NewestSlot()
    stamp = 1_795_873_152_642_000_123
    assert (stamp - 1) / 1e9 == stamp / 1e9  # what the float cannot tell apart
    assert slot.offer("newest", stamp / 1e9, stamp)
    assert not slot.offer("1 ns older", (stamp - 1) / 1e9, stamp - 1)
    assert slot.take() == ("newest", stamp / 1e9, 1)


def test_the_pump_sends_the_newest_frame_once_the_send_before_completed() -> None:
    """While frame 1's send blocks, frames 2 to 5 come: 5 alone goes next, numbered 2."""
    sent: list[tuple[str, float, int]] = []
    released, cond = threading.Event(), threading.Condition()

    def send(payload: str, generated_at: float, seq: int) -> None:
        with cond:
            sent.append((payload, generated_at, seq))
            cond.notify_all()
        released.wait(WAIT)

    pump: NewestPump[str] = NewestPump("x", send)
    assert pump.offer("f1", 1.0)
    with cond:
        assert cond.wait_for(lambda: len(sent) == 1, WAIT)
    assert all(pump.offer(f"f{k}", float(k)) for k in range(2, 6))
    assert not pump.offer("late", 0.5)
    released.set()
    with cond:
        assert cond.wait_for(lambda: len(sent) == 2, WAIT)
    assert sent == [("f1", 1.0, 1), ("f5", 5.0, 2)]
    assert pump.close()
    assert pump.counts == ("6 frames offered, 2 sent, 3 replaced unsent by a newer one, "
                           "1 refused as older")


def test_newest_only_push_needs_a_blocking_put_and_keeps_zenohs_queues_small() -> None:
    with pytest.raises(ValueError, match="congestion block"):
        BaselineFollowerOptions("s", ("a",), "push", 100.0, congestion="drop",
                                newest_only=True)
    with pytest.raises(ValueError, match="push and tcp"):
        BaselineFollowerOptions("s", ("a",), "udp", 100.0, receiver="127.0.0.1:9",
                                newest_only=True)
    with pytest.raises(ValueError, match="congestion block"):
        PushSender(None, "s", "a", "drop", capacity=None)  # type: ignore[arg-type]
    spec = SessionSpec.loopback("peer", connect_ports=[7447])
    options = BaselineFollowerOptions("s", ("a",), "push", 100.0, newest_only=True)
    config = follower_session_spec(spec, options, "a").config()
    assert config.get_json("transport/link/tx/queue/size/data") == "1"
    assert config.get_json("transport/link/tcp/so_sndbuf") == NEWEST_ZENOH[1].split(":")[1]
    fifo = BaselineFollowerOptions("s", ("a",), "push", 100.0)
    assert follower_session_spec(spec, fifo, "a") == spec
    given = SessionSpec(cfg=("transport/link/tx/queue/size/data:3",))
    assert follower_session_spec(given, options, "a").config().get_json(
        "transport/link/tx/queue/size/data") == "3"  # the user's --cfg wins


@pytest.mark.parametrize("kind", ["push", "tcp"])
def test_newest_only_senders_deliver_to_the_baselines_receivers(
        kind: str, sessions: Sessions) -> None:
    """Each frame offered once the one before arrived: every one is delivered, numbered
    in order, to the receiver of the FIFO baseline, which names a push system by its
    congestion control (block)."""
    port = free_tcp_port()
    sessions.router(port)
    watcher = Samples(sessions.node(port), "wiswarm/s1/leader/stats")
    frames = Frames()
    bind = f"127.0.0.1:{free_tcp_port()}"
    with Receiver(sessions.node(port), "s1", kind, bind, on_frame=frames, stats_period=0.1):
        sender: PushSender | TcpSender
        if kind == "push":
            session = sessions.node(port)
            sender = PushSender(session, "s1", "a", capacity=None, clock=Clock())
            assert sender.congestion_control == zenoh.CongestionControl.BLOCK
            wait_until_known(session, "wiswarm/s1/a/push")
        else:
            sender = TcpSender("a", bind, capacity=None, clock=Clock(), send_buffer=4096)
        for k in range(1, 4):
            assert sender.offer(FRAME)
            frames.wait_for({"a"}, k)
        if isinstance(sender, TcpSender):  # the kernel doubles what it is given
            assert sender._socket is not None
            assert sender._socket.getsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF) == 8192
        watcher.wait("the receiver's stats", lambda s: any(
            r["followers"] == ["a"] for r in s.stats("wiswarm/s1/leader/stats")))
        sender.close()
    assert [payload for _, payload, _, _ in frames.of("a")] == [FRAME] * 3
    assert sender.queue.counts.startswith("3 frames offered, 3 sent, 0 replaced")
    label = "push-block" if kind == "push" else "tcp"
    assert watcher.stats("wiswarm/s1/leader/stats")[-1]["policy"] == label
