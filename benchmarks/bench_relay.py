"""What the delay relay adds beyond its delay, on loopback: per-message one-way latency
(ping-pong of small messages, TCP_NODELAY) and per-chunk latency of steady streams at
several rates, each against the same traffic sent directly.

Send and arrival times come from one clock (all in this process), so one-way latencies
are exact. The relay runs on threads of this process unless ``--process``, which runs
``python -m wiswarm_zenoh.testbed.relay`` as it would run inside a namespace (its write
lateness is then not known here). The target of the issue: the added delay within 2 ms
of the delay (median), and a stream's latency within delay + 2 ms (p95), not growing.

    .venv/bin/python benchmarks/bench_relay.py
    .venv/bin/python benchmarks/bench_relay.py --delay 50ms --rates 10,100,200 --process
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import socket
import statistics
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

from wiswarm_zenoh.testbed.relay import DelayRelay, RelayCounters
from wiswarm_zenoh.units import parse_seconds

LOCAL = "127.0.0.1"
WAIT = 30.0


@contextlib.contextmanager
def _path(delay: float | None, process: bool) -> Iterator[tuple[socket.socket, socket.socket,
                                                               DelayRelay | None]]:
    """A connected pair (client, server end), through a relay of ``delay`` unless None."""
    with contextlib.ExitStack() as stack:
        server = stack.enter_context(socket.create_server((LOCAL, 0)))
        server.settimeout(WAIT)
        port, relay = server.getsockname()[1], None
        if delay is not None and process:
            child = subprocess.Popen(
                [sys.executable, "-m", "wiswarm_zenoh.testbed.relay", "--listen", f"{LOCAL}:0",
                 "--target", f"{LOCAL}:{port}", "--delay", str(delay)],
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

            def finish() -> None:  # its summary names the latest write
                child.terminate()
                print(f"  (relay: {child.communicate(timeout=WAIT)[1].strip()})")

            stack.callback(finish)
            assert child.stdout is not None
            found = re.search(r":(\d+), relaying", child.stdout.readline())
            assert found, "the relay did not start"
            port = int(found.group(1))
        elif delay is not None:
            relay = stack.enter_context(DelayRelay((LOCAL, 0), (LOCAL, port), delay))
            port = relay.port
        client = stack.enter_context(socket.create_connection((LOCAL, port), WAIT))
        end = stack.enter_context(server.accept()[0])
        for sock in (client, end):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        yield client, end, relay


def _recv_exact(sock: socket.socket, size: int) -> bytes:
    buf, got = bytearray(size), 0
    while got < size:
        n = sock.recv_into(memoryview(buf)[got:])
        if n == 0:
            raise EOFError
        got += n
    return bytes(buf)


def _ping_pong(client: socket.socket, end: socket.socket, count: int) -> list[float]:
    """One-way latencies of ``count`` 64-byte messages, there and back."""
    latencies: list[float] = []

    def echo() -> None:
        for _ in range(count):
            sent = struct.unpack("!d", _recv_exact(end, 64)[:8])[0]
            latencies.append(time.monotonic() - sent)
            end.sendall(struct.pack("!d", time.monotonic()).ljust(64, b"."))

    echoer = threading.Thread(target=echo)
    echoer.start()
    for _ in range(count):
        client.sendall(struct.pack("!d", time.monotonic()).ljust(64, b"."))
        sent = struct.unpack("!d", _recv_exact(client, 64)[:8])[0]
        latencies.append(time.monotonic() - sent)
    echoer.join(WAIT)
    return latencies


def _stream(client: socket.socket, end: socket.socket, rate: float, size: int,
            seconds: float) -> tuple[list[float], float]:
    """Per-chunk latencies of ``size``-byte chunks sent at ``rate`` B/s; the rate offered."""
    count, interval, body = int(rate * seconds / size), size / rate, os.urandom(size)

    def send() -> float:
        start = time.monotonic()
        for i in range(count):
            time.sleep(max(0.0, start + i * interval - time.monotonic()))
            client.sendall(struct.pack("!d", time.monotonic()) + body[8:])
        return count * size / (time.monotonic() - start)

    def receive() -> list[float]:
        out = []
        for _ in range(count):
            sent = struct.unpack("!d", _recv_exact(end, size)[:8])[0]
            out.append(time.monotonic() - sent)
        return out

    with ThreadPoolExecutor(2) as pool:
        offered, received = pool.submit(send), pool.submit(receive)
        return received.result(WAIT), offered.result(WAIT)


def _ms(latencies: list[float], minus: float) -> str:
    q = statistics.quantiles(latencies, n=100, method="inclusive")
    return (f"median {(q[49] - minus) * 1e3:6.3f}  p95 {(q[94] - minus) * 1e3:6.3f}  "
            f"p99 {(q[98] - minus) * 1e3:6.3f}  max {(max(latencies) - minus) * 1e3:6.3f}")


def _lateness(counters: RelayCounters | None) -> str:
    if counters is None:
        return ""
    return (f"  writes >1 ms late {counters.late_chunks}/{counters.chunks}, latest "
            f"{counters.max_lateness_s * 1e3:.2f} ms, peak held "
            f"{counters.peak_held_bytes / 1e6:.2f} MB")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--delay", type=parse_seconds, default=0.02)
    parser.add_argument("--rates", default="10,50,100", help="stream rates, MB/s")
    parser.add_argument("--chunk", type=int, default=64 * 1024, help="stream chunk, bytes")
    parser.add_argument("--seconds", type=float, default=2.0, help="per stream")
    parser.add_argument("--messages", type=int, default=100, help="ping-pongs")
    parser.add_argument("--process", action="store_true", help="the relay in a process")
    args = parser.parse_args()
    delay = args.delay
    print(f"delay {delay * 1e3:g} ms each way; ms beyond the delay "
          f"({'relay process' if args.process else 'relay threads in this process'})")
    with _path(None, False) as (client, end, _):
        direct = _ping_pong(client, end, args.messages)
    with _path(delay, args.process) as (client, end, relay):
        relayed = _ping_pong(client, end, args.messages)
        counters = relay.counters() if relay else None
    print(f"ping-pong  direct   {_ms(direct, 0.0)}")
    print(f"ping-pong  relayed  {_ms(relayed, delay)}{_lateness(counters)}")
    added = statistics.median(relayed) - statistics.median(direct) - delay
    print(f"  added beyond the delay (medians): {added * 1e3:.3f} ms (target: within 2 ms)")
    for rate in (float(r) * 1e6 for r in args.rates.split(",")):
        with _path(None, False) as (client, end, _):
            plain, _offered = _stream(client, end, rate, args.chunk, args.seconds)
        with _path(delay, args.process) as (client, end, relay):
            latencies, offered = _stream(client, end, rate, args.chunk, args.seconds)
            counters = relay.counters() if relay else None
        tenth = len(latencies) // 10
        growth = statistics.median(latencies[-tenth:]) - statistics.median(latencies[:tenth])
        print(f"{rate / 1e6:5g} MB/s  direct   {_ms(plain, 0.0)}")
        print(f"{offered / 1e6:5.1f} MB/s  relayed  {_ms(latencies, delay)}  growth "
              f"{growth * 1e3:+.3f}{_lateness(counters)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
