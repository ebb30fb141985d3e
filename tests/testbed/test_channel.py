"""The emulated channel: it carries its rate each way, its counters see what crossed,
and nothing is left behind however the process that built it ends."""

from __future__ import annotations

import logging
import multiprocessing
import os
import signal
import socket
import subprocess
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from multiprocessing.queues import Queue
from typing import Any, TypeVar

import pytest

from wiswarm_zenoh.testbed import (
    Channel,
    ChannelSpec,
    cleanup_leftovers,
    enter,
    list_channels,
    remove_channel,
    unavailable_reason,
)
from wiswarm_zenoh.testbed.channel_records import STATE_DIR
from wiswarm_zenoh.testbed.netns import entered

T = TypeVar("T")
WAIT = 30.0
WARMUP = 0.3  # s of bulk before the window: the bucket's initial burst is spent by then
WINDOW = 1.5  # s over which the rate is measured
CHUNK = 64 * 1024

needs_root = pytest.mark.testbed


def _in_ns(ns: str, make: Callable[[], T]) -> T:
    """``make()`` on a thread inside ``ns``: a socket made there stays in that namespace."""
    with ThreadPoolExecutor(1, initializer=enter, initargs=(ns,)) as pool:
        return pool.submit(make).result()


@dataclass(frozen=True)
class Bulk:
    received: int  # payload bytes over the whole transfer
    goodput_bps: float  # payload bits/s over the window
    sent_counted: int  # growth of the tbf's Sent counter over the whole transfer


def _bulk(channel: Channel, *, downlink: bool = False) -> Bulk:
    """TCP bulk across the channel (followers -> leader, or back) for WARMUP + WINDOW s."""
    if downlink:
        src_ns, dst_ns, dst_addr, counters = (channel.leader_ns, channel.follower_ns,
                                              channel.follower_addr, channel.downlink)
    else:
        src_ns, dst_ns, dst_addr, counters = (channel.follower_ns, channel.leader_ns,
                                              channel.leader_addr, channel.uplink)
    server = _in_ns(dst_ns, lambda: socket.create_server((dst_addr, 0)))
    port = server.getsockname()[1]
    client = _in_ns(src_ns, lambda: socket.create_connection((dst_addr, port), timeout=WAIT))
    conn, _ = server.accept()
    conn.settimeout(WAIT)
    stop = threading.Event()

    def send() -> None:
        payload = b"\0" * CHUNK
        with client:
            while not stop.is_set():
                client.sendall(payload)

    before = counters()
    sender = threading.Thread(target=send)
    sender.start()
    received = 0
    # (when received, payload received)
    opened: tuple[float, int] | None = None
    closed: tuple[float, int] | None = None
    started = time.monotonic()
    with server, conn:
        while data := conn.recv(CHUNK):
            received += len(data)
            now = time.monotonic()
            if opened is None and now - started >= WARMUP:
                opened = (now, received)
            elif opened is not None and closed is None and now - opened[0] >= WINDOW:
                closed = (now, received)
                stop.set()
    sender.join(WAIT)
    assert opened is not None and closed is not None
    return Bulk(received, (closed[1] - opened[1]) * 8 / (closed[0] - opened[0]),
                counters().sent_bytes - before.sent_bytes)


def _assert_rate(bulk: Bulk, rate_bps: int) -> None:
    print(f"rate {rate_bps / 1e6:g} Mbit/s: goodput {bulk.goodput_bps / 1e6:.2f} Mbit/s "
          f"({bulk.goodput_bps / rate_bps - 1:+.1%}), the tbf sent "
          f"{bulk.sent_counted / bulk.received:.3f} x the payload")
    assert 0.9 * rate_bps <= bulk.goodput_bps <= 1.1 * rate_bps
    # What the tbf sent, to the payload received, over the whole transfer: every payload
    # byte crossed it, with TCP/IP's headers (some 4.5 %) and few retransmissions. Bytes,
    # not a rate over the window: reading tc's counters takes a while on a busy machine,
    # and a loaded run measured the wire 33 % under the goodput that way.
    assert bulk.received <= bulk.sent_counted <= 1.15 * bulk.received


def _netns_names() -> str:
    return subprocess.run(["ip", "netns", "list"], capture_output=True, text=True,
                          check=True).stdout


def _assert_gone(run_id: str, leader_ns: str, follower_ns: str) -> None:
    names = _netns_names()
    assert leader_ns not in names and follower_ns not in names
    assert run_id not in list_channels()
    assert not (STATE_DIR / f"{run_id}.json").exists()


def test_the_spec_names_the_field_it_rejects() -> None:
    for kwargs, field in (({"rate_bps": 0}, "rate_bps"), ({"rate_bps": 2.0e7}, "rate_bps"),
                          ({"down_rate_bps": 10**12}, "down_rate_bps"),
                          ({"queue_s": 0.0}, "queue_s"), ({"queue_s": float("nan")}, "queue_s"),
                          ({"burst_bytes": 1500}, "burst_bytes"),
                          ({"rate_bps": 8_000, "burst_bytes": 10**8}, "burst_bytes"),
                          ({"rate_bps": 10**11, "queue_s": 1.0}, "queue_s")):
        with pytest.raises(ValueError, match=field):
            ChannelSpec(**kwargs)
    assert ChannelSpec().down_bps == 20_000_000
    assert ChannelSpec(down_rate_bps=5_000_000).down_bps == 5_000_000


def test_unavailable_says_what_is_missing_and_points_to_the_simulator() -> None:
    def which(tool: str) -> str | None:
        return None if tool == "tc" else f"/usr/sbin/{tool}"

    not_root = unavailable_reason(1000, which)
    assert not_root is not None and "root" in not_root and "wiswarm sim link" in not_root
    no_tc = unavailable_reason(0, which)
    assert no_tc is not None and "`tc`" in no_tc and "`ip`" not in no_tc
    assert "wiswarm sim link" in no_tc
    assert unavailable_reason(0, lambda tool: f"/usr/sbin/{tool}") is None


@needs_root
def test_the_uplink_carries_its_rate_and_set_rate_changes_it() -> None:
    with Channel() as channel:
        _assert_rate(_bulk(channel), 20_000_000)
        channel.set_rate(5_000_000)
        assert Channel.attach(channel.run_id).spec == channel.spec == ChannelSpec(5_000_000)
        _assert_rate(_bulk(channel), 5_000_000)


@needs_root
def test_the_downlink_is_shaped_on_its_own() -> None:
    spec = ChannelSpec(rate_bps=20_000_000, down_rate_bps=8_000_000, queue_s=0.1)
    with Channel(spec) as channel:
        assert Channel.attach(channel.run_id).spec == spec
        _assert_rate(_bulk(channel, downlink=True), 8_000_000)


@needs_root
def test_two_channels_at_once_have_their_own_names_and_addresses() -> None:
    with Channel() as one, Channel(name=f"t{os.getpid():x}") as two:
        assert one.run_id != two.run_id and two.run_id == f"t{os.getpid():x}"
        assert one.leader_addr != two.leader_addr
        assert {one.run_id, two.run_id} <= set(list_channels())
        with pytest.raises(ValueError, match="exists already"):
            Channel(name=two.run_id).build()
        assert "leader side: router + leader in" in two.describe()
        assert f"follower side: followers in {two.follower_ns} at {two.follower_addr}" in (
            two.describe())
        assert _bulk(two).received > 0  # each carries traffic
    _assert_gone(one.run_id, one.leader_ns, one.follower_ns)
    _assert_gone(two.run_id, two.leader_ns, two.follower_ns)


@needs_root
def test_channels_built_from_several_threads_at_once_do_not_collide() -> None:
    """As a study's parallel workers build theirs."""
    channels = [Channel() for _ in range(3)]
    try:
        with ThreadPoolExecutor(len(channels)) as pool:
            list(pool.map(Channel.build, channels))
        assert len({c.run_id for c in channels}) == len({c.leader_addr for c in channels}) == 3
    finally:
        for channel in channels:
            channel.close()
    for channel in channels:
        _assert_gone(channel.run_id, channel.leader_ns, channel.follower_ns)


@needs_root
def test_closing_removes_the_veth_even_while_a_process_holds_the_namespace() -> None:
    closed = threading.Event()
    with Channel() as channel:
        def linger() -> list[str]:
            enter(channel.leader_ns)  # this thread keeps the namespace itself alive
            closed.wait(WAIT)
            return sorted(name for _, name in socket.if_nameindex())

        with ThreadPoolExecutor(1) as pool:
            inside = pool.submit(linger)
            channel.close()
            closed.set()
            assert inside.result() == ["lo"]  # no veth, so no qdisc either
        channel.close()  # a second close does nothing
    _assert_gone(channel.run_id, channel.leader_ns, channel.follower_ns)


@needs_root
def test_an_exception_inside_the_with_removes_everything() -> None:
    built: list[Channel] = []
    with pytest.raises(KeyError), Channel() as channel:
        built.append(channel)
        raise KeyError("boom")
    (channel,) = built
    _assert_gone(channel.run_id, channel.leader_ns, channel.follower_ns)


def _build_and_wait(report: Queue[Any]) -> None:
    """A spawn child: builds a channel, says which, and waits to be killed."""
    channel = Channel().build()
    report.put((channel.run_id, channel.leader_ns, channel.follower_ns))
    signal.pause()


@needs_root
def test_a_channel_whose_process_was_killed_is_removed_by_the_next_build(
        caplog: pytest.LogCaptureFixture) -> None:
    ctx = multiprocessing.get_context("spawn")
    report: Queue[Any] = ctx.Queue()
    child = ctx.Process(target=_build_and_wait, args=(report,))
    child.start()
    try:
        run_id, leader_ns, follower_ns = report.get(timeout=WAIT)
    finally:
        assert child.pid is not None
        os.kill(child.pid, signal.SIGKILL)
        child.join(WAIT)
    assert run_id in list_channels()  # the killed process could not clean up
    caplog.set_level(logging.WARNING, logger="wiswarm_zenoh.testbed.channel")
    with Channel() as channel:
        _assert_gone(run_id, leader_ns, follower_ns)
        assert channel.run_id in list_channels()
    assert f"removed leftover testbed channel {run_id}" in caplog.text
    assert run_id not in cleanup_leftovers()


@needs_root
def test_persistent_channels_are_not_leftovers_and_attach_finds_them() -> None:
    channel = Channel(ChannelSpec(rate_bps=10_000_000), name=f"p{os.getpid():x}")
    channel.build(persistent=True)
    try:
        assert channel.run_id not in cleanup_leftovers()
        attached = Channel.attach(channel.run_id)
        assert (attached.spec, attached.leader_addr, attached.follower_addr) == (
            channel.spec, channel.leader_addr, channel.follower_addr)
        assert attached.persistent
    finally:
        remove_channel(channel.run_id)
    _assert_gone(channel.run_id, channel.leader_ns, channel.follower_ns)
    with pytest.raises(LookupError):
        Channel.attach(channel.run_id)
    with pytest.raises(LookupError):
        remove_channel(channel.run_id)



@needs_root
def test_a_thread_can_enter_one_side_and_come_back() -> None:
    """``entered``: inside, the leader side's address is local; after, the thread is back
    in the namespace it came from, where that address is not."""
    home = os.readlink("/proc/thread-self/ns/net")
    with Channel() as channel:
        with entered(channel.leader_ns):
            assert os.readlink("/proc/thread-self/ns/net") != home
            with socket.socket() as sock:
                sock.bind((channel.leader_addr, 0))
        assert os.readlink("/proc/thread-self/ns/net") == home
        with socket.socket() as sock, pytest.raises(OSError):
            sock.bind((channel.leader_addr, 0))
