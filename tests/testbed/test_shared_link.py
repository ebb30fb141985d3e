"""The user-space shared link (the relay with a ``SharedLink``): it holds its rate with
several connections, each connection's bytes arrive intact and in order, every
connection waits in the one FIFO, and it stops cleanly, a reader waiting for room too.

All on loopback in this process, no root."""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import socket
import threading
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager

import pytest

from tests.transport.helpers import eventually
from wiswarm_zenoh.testbed import ChannelSpec
from wiswarm_zenoh.testbed.relay import DelayRelay
from wiswarm_zenoh.testbed.shaper import MSS, PACKET_HEADERS, SharedLink, wire_bytes

from .relay_helpers import LOCAL, WAIT, drain, recv_exact, run, send_and_close

pytestmark = pytest.mark.usefixtures("no_relay_thread_left")

RATE = 4_000_000  # 500 kB/s: the 32 kB bucket covers a 64 ms stall of a loaded machine
SPEC = ChannelSpec(rate_bps=RATE)
Linked = tuple[DelayRelay, SharedLink, list[socket.socket], list[socket.socket]]


@contextmanager
def linked(connections: int, spec: ChannelSpec = SPEC) -> Iterator[Linked]:
    """A relay with a shared link to a fresh server and ``connections`` connections
    through it: (relay, link, clients, server ends), ends in the clients' order."""
    with ExitStack() as stack:
        server = stack.enter_context(socket.create_server((LOCAL, 0)))
        server.settimeout(WAIT)
        link = SharedLink(spec)
        relay = stack.enter_context(DelayRelay((LOCAL, 0), server.getsockname(), 0.0,
                                               link=link))
        clients, ends = [], []
        for _ in range(connections):  # one at a time, so each end is its client's
            clients.append(stack.enter_context(
                socket.create_connection((LOCAL, relay.port), WAIT)))
            ends.append(stack.enter_context(server.accept()[0]))
        for sock in (*clients, *ends):
            sock.settimeout(WAIT)
        yield relay, link, clients, ends


def test_wire_bytes_count_the_headers_of_mss_sized_packets() -> None:
    assert wire_bytes(0) == 0
    assert wire_bytes(1) == 1 + PACKET_HEADERS
    assert wire_bytes(MSS) == MSS + PACKET_HEADERS == 1514  # a full Ethernet frame
    assert wire_bytes(MSS + 1) == MSS + 1 + 2 * PACKET_HEADERS


@pytest.mark.parametrize("connections", [4, 8])
def test_several_connections_share_the_rate_and_get_all_of_it(connections: int) -> None:
    """Bulk streams on every connection: together they get the rate within 10 % (wire
    bytes: what the receivers got, with the headers tbf would count), each a share."""
    received = [0] * connections
    stop = threading.Event()
    with linked(connections) as (relay, link, clients, ends):
        def send(sock: socket.socket) -> None:  # until stopped, or reset by relay.stop()
            with contextlib.suppress(OSError):
                while not stop.is_set():
                    sock.sendall(bytes(16 * 1024))

        def count(index: int) -> None:
            with contextlib.suppress(OSError):
                while data := ends[index].recv(1 << 20):
                    received[index] += len(data)

        threads = [threading.Thread(target=send, args=(c,), daemon=True) for c in clients]
        threads += [threading.Thread(target=count, args=(i,), daemon=True)
                    for i in range(connections)]
        for thread in threads:
            thread.start()
        stop.wait(1.0)  # past the bucket's first burst
        first, start = list(received), time.monotonic()
        stop.wait(3.0)
        got = [now - before for now, before in zip(received, first, strict=True)]
        elapsed = time.monotonic() - start
        stop.set()
        counted = link.up.counters()
        relay.stop()  # resets the connections: the threads end
        for thread in threads:
            thread.join(WAIT)
    payload_rate = sum(got) * 8 / elapsed
    wire_rate = payload_rate * (MSS + PACKET_HEADERS) / MSS
    assert wire_rate == pytest.approx(RATE, rel=0.10)
    # Nobody starved. A share is uneven over 3 s (at 8 connections, some 90 of the 16 kB
    # writes in all, by 16 threads that a busy machine schedules unevenly: one got 0.28
    # of the mean, loaded); a starved connection gets nothing.
    assert min(got) > 0.1 * sum(got) / connections, got
    assert counted.dropped == 0 and counted.overlimits > 0  # it waited for tokens


def test_each_connection_arrives_intact_and_in_order() -> None:
    payloads = [os.urandom(300_000 + k) for k in range(3)]
    with linked(3, ChannelSpec(rate_bps=40_000_000)) as (_, _, clients, ends):
        results = run(*(functools.partial(send_and_close, c, p)
                        for c, p in zip(clients, payloads, strict=True)),
                      *(functools.partial(drain, e) for e in ends))
    assert results[3:] == [(len(p), hashlib.sha256(p).hexdigest()) for p in payloads]


def test_a_connection_waits_behind_what_others_queued_before_it() -> None:
    """One FIFO for all: a message sent while another connection's 150 kB wait in the
    link leaves after them, at the rate, not once tokens for itself are there, as it
    would with a queue per connection."""
    bulk = 150_000
    with linked(2) as (_, link, (a, b), (end_a, end_b)):
        a.sendall(os.urandom(bulk))
        eventually("the bulk is in the link", lambda: _taken_in(link) >= wire_bytes(bulk))
        ahead, sent = link.up.counters().backlog_bytes, time.monotonic()
        b.sendall(b"ping")
        assert recv_exact(end_b, 4) == b"ping"
        waited = time.monotonic() - sent
        recv_exact(end_a, bulk)
    assert ahead > 50_000  # the bucket's 32 kB burst is spent: the rest waits
    assert waited >= 0.8 * ahead * 8 / RATE, (waited, ahead)


def test_stopping_releases_a_reader_waiting_for_room_and_frees_the_port() -> None:
    """At 100 kbit/s the link's FIFO (35 kB) fills at once: the connection's reader then
    waits for room. Stopping wakes it, resets the connection and joins every thread (the
    fixture checks none is left)."""
    with linked(1, ChannelSpec(rate_bps=100_000)) as (relay, link, (client,), (end,)):
        sender = threading.Thread(target=lambda: _send_until_reset(client), daemon=True)
        sender.start()
        deadline = time.monotonic() + WAIT
        while link.up.counters().backlog_bytes < link.up.limit - 2 * link.up.chunk:
            assert time.monotonic() < deadline, "the link's FIFO never filled"
            time.sleep(0.01)
        started = time.monotonic()
        relay.stop()
        assert time.monotonic() - started < 2.0
        sender.join(WAIT)
        assert not sender.is_alive()  # its connection was reset
        with pytest.raises(ConnectionResetError):  # and so was the target's
            while end.recv(1 << 16):
                pass
        port = relay.port
    with socket.create_server((LOCAL, port)):  # nobody holds it
        pass


def _taken_in(link: SharedLink) -> int:
    """Wire bytes the uplink has taken in: let out or waiting."""
    counted = link.up.counters()
    return counted.sent_bytes + counted.backlog_bytes


def _send_until_reset(sock: socket.socket) -> None:
    with contextlib.suppress(OSError):
        while True:
            sock.sendall(bytes(64 * 1024))
