"""The delay relay: bytes cross intact, each way late by the delay and no more, a fast
stream keeps its latency, ends and errors cross, and a stalled target pushes back.

All on loopback, in this process: send and arrival times are read from one clock, so
one-way latencies are measured exactly, not halved round trips."""

from __future__ import annotations

import hashlib
import os
import socket
import statistics
import struct
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from contextlib import ExitStack
from dataclasses import dataclass

import pytest

from wiswarm_zenoh.testbed.relay import (
    RelayCounters,
)

from .relay_helpers import (
    DELAY,
    SLACK,
    WAIT,
    direct,
    drain,
    recv_exact,
    relayed,
    run,
    send_and_close,
)

pytestmark = pytest.mark.usefixtures("no_relay_thread_left")


def test_bytes_cross_both_ways_intact() -> None:
    up, down = os.urandom(6_000_017), os.urandom(5_000_011)
    with relayed(0.005) as (relay, client, end):
        _, _, got_up, got_down = run(lambda: send_and_close(client, up),
                                      lambda: send_and_close(end, down),
                                      lambda: drain(end), lambda: drain(client))
        assert got_up == (len(up), hashlib.sha256(up).hexdigest())
        assert got_down == (len(down), hashlib.sha256(down).hexdigest())
        assert relay.wait_idle(WAIT)  # both halves closed: the relay closed it
        counters = relay.counters()
    assert (counters.to_target_bytes, counters.from_target_bytes) == (len(up), len(down))
    assert (counters.connections, counters.active, counters.unreachable) == (1, 0, 0)


def _one_way(client: socket.socket, end: socket.socket, count: int
             ) -> tuple[list[float], list[float]]:
    """Ping-pong ``count`` small messages: one-way latencies (there, back), in seconds."""
    there: list[float] = []

    def echo() -> None:
        for _ in range(count):
            sent = struct.unpack("!d", recv_exact(end, 64)[:8])[0]
            there.append(time.monotonic() - sent)
            end.sendall(struct.pack("!d", time.monotonic()).ljust(64, b"."))

    back: list[float] = []
    with ThreadPoolExecutor(1) as pool:
        echoed = pool.submit(echo)
        for _ in range(count):
            client.sendall(struct.pack("!d", time.monotonic()).ljust(64, b"."))
            sent = struct.unpack("!d", recv_exact(client, 64)[:8])[0]
            back.append(time.monotonic() - sent)
        echoed.result(WAIT)
    return there, back


def test_each_way_is_late_by_the_delay_within_2_ms() -> None:
    with direct() as (client, end):
        plain_ways = _one_way(client, end, 40)
    with relayed(DELAY) as (relay, client, end):
        relayed_ways = _one_way(client, end, 30)
    counters = relay.counters()  # stopped, its threads joined: each write is counted (a
    # write is counted once sent, so the last echo can come back before it is)
    for way, plain, delayed in zip(("there", "back"), plain_ways, relayed_ways, strict=True):
        added = statistics.median(delayed) - statistics.median(plain)
        print(f"{way}: direct median {statistics.median(plain) * 1e6:.0f} us, relayed "
              f"median {statistics.median(delayed) * 1e3:.3f} ms (max "
              f"{max(delayed) * 1e3:.3f}), added {added * 1e3:.3f} ms")
        assert abs(added - DELAY) <= SLACK
        assert min(delayed) >= DELAY  # never early
    print(f"{counters.late_chunks} of {counters.chunks} chunks written over 1 ms after due, "
          f"the latest {counters.max_lateness_s * 1e3:.3f} ms")
    assert counters.chunks == 2 * 30  # each message one chunk: none split, none merged


@dataclass(frozen=True)
class Stream:
    latencies: list[float]  # of each chunk, in order: arrival (last byte) - send
    offered_bps: float  # bytes/s the sender managed to offer
    counters: RelayCounters | None  # None: sent directly, the control

    @property
    def p95(self) -> float:
        return statistics.quantiles(self.latencies, n=20, method="inclusive")[18]

    @property
    def growth(self) -> float:
        """Median latency of the last tenth of the chunks against the first tenth's."""
        tenth = len(self.latencies) // 10
        return (statistics.median(self.latencies[-tenth:])
                - statistics.median(self.latencies[:tenth]))

    def __str__(self) -> str:
        lat, c = self.latencies, self.counters
        return (f"{len(lat)} chunks at {self.offered_bps / 1e6:.1f} MB/s "
                f"{'direct' if c is None else 'relayed'}: latency min {min(lat) * 1e3:.3f} ms, "
                f"median {statistics.median(lat) * 1e3:.3f}, p95 {self.p95 * 1e3:.3f}, max "
                f"{max(lat) * 1e3:.3f}; growth {self.growth * 1e3:+.3f} ms" + (
                    "" if c is None else f"; {c.late_chunks} of {c.chunks} writes over 1 ms "
                    f"late, the latest {c.max_lateness_s * 1e3:.3f} ms; peak held "
                    f"{c.peak_held_bytes / 1e6:.2f} MB"))


def _stream(rate: float, size: int, duration: float, through_relay: bool = True) -> Stream:
    """``size``-byte chunks at ``rate`` bytes/s through a relay of DELAY (or directly),
    each stamped with its send time; checks they all arrive, in order."""
    count, interval = int(rate * duration / size), size / rate
    body = os.urandom(size)
    with ExitStack() as stack:
        relay, client, end = (stack.enter_context(relayed(DELAY)) if through_relay
                              else (None, *stack.enter_context(direct())))

        def send() -> float:
            start = time.monotonic()
            for i in range(count):
                time.sleep(max(0.0, start + i * interval - time.monotonic()))
                client.sendall(struct.pack("!Qd", i, time.monotonic()) + body[16:])
            client.shutdown(socket.SHUT_WR)
            return count * size / (time.monotonic() - start)

        def receive() -> list[float]:
            latencies = []
            for i in range(count):
                seq, sent = struct.unpack("!Qd", recv_exact(end, size)[:16])
                latencies.append(time.monotonic() - sent)
                assert seq == i
            assert end.recv(1) == b""
            return latencies

        with ThreadPoolExecutor(2) as pool:
            offered, received = pool.submit(send), pool.submit(receive)
            stream = Stream(received.result(WAIT), offered.result(WAIT),
                            None if relay is None else relay.counters())
    assert stream.counters is None or stream.counters.to_target_bytes == count * size
    return stream


# Sleeps 1 ms at a time for argv[1] seconds, then prints the worst oversleep: how long
# this machine kept a ready process from running meanwhile.
CANARY = """
import sys, time
print("ready", flush=True)
worst, end = 0.0, time.monotonic() + float(sys.argv[1])
while time.monotonic() < end:
    start = time.monotonic()
    time.sleep(0.001)
    worst = max(worst, time.monotonic() - start - 0.001)
print(worst)
"""


def _stream_watched(rate: float, size: int, duration: float) -> tuple[Stream, float]:
    """A relayed stream, and the worst stall a separate process saw meanwhile."""
    canary = subprocess.Popen([sys.executable, "-c", CANARY, str(duration + DELAY)],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert canary.stdout is not None and canary.stdout.readline() == "ready\n"
        stream = _stream(rate, size, duration)
        return stream, float(canary.communicate(timeout=WAIT)[0])
    finally:
        canary.kill()
        canary.wait()


def test_a_fast_stream_keeps_its_latency() -> None:
    """50 MB/s of 64 kB chunks for 1 s: the latency does not grow, as it would behind a
    queue in the relay, which holds no more than what is in flight. Every chunk arrives,
    in order, never before its delay, in every run.

    The timing bounds are the relay's, but a busy machine alone breaks them: a process
    kept from running for 5 ms or more (seen often on a shared VM) delays whatever is in
    flight. So a process sleeping 1 ms at a time watches each run. Passes if one of three
    runs is within the bounds; skipped if each run over them was watched stalling; fails
    otherwise (a relay that queued is over in every run, stalls or none)."""
    rate, size, duration = 50e6, 64 * 1024, 1.0
    runs: list[tuple[Stream, float]] = []
    for attempt in range(1, 4):
        stream, stall = _stream_watched(rate, size, duration)
        print(f"run {attempt}: {stream}; worst stall meanwhile {stall * 1e3:.1f} ms")
        assert min(stream.latencies) >= DELAY
        assert stream.counters is not None
        # A queue's signatures: latency growing over the run, and more held than is in
        # flight. The p95 and the late writes (printed) are the machine's as much as the
        # relay's: a clean-clone run had them over in three runs with 4.6 ms stalls.
        if (stream.offered_bps >= 0.95 * rate and stream.growth <= SLACK / 2
                and stream.counters.peak_held_bytes <= 2 * rate * DELAY):
            return
        runs.append((stream, stall))
    if all(stall >= 0.005 for _, stall in runs):
        pytest.skip("this machine is too busy to time a relay: in every run a process was "
                    "kept from running for 5 ms or more (worst stalls "
                    f"{', '.join(f'{stall * 1e3:.0f}' for _, stall in runs)} ms)")
    pytest.fail("over the bounds in three runs, " + "; ".join(
        f"{stream} (worst stall {stall * 1e3:.1f} ms)" for stream, stall in runs))
