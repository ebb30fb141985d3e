"""One robot's link degraded at run time (issue 41): on the tbf channel its process's
flows capped while the others take the rest of the uplink, on the WiFi medium its
station's PHY rate lowered; bad requests refused in one line."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

import pytest

from wiswarm_zenoh.testbed import Channel, enter

RATE = 20_000_000
CAP = RATE // 4
SETTLE = 1.0  # s for the queues and TCP to take a change in
WINDOW = 2.5  # s over which the goodputs are measured
# A sender in the follower side's namespace: TCP bulk to the address and port it is given.
SENDER = """
import socket, sys
conn = socket.create_connection((sys.argv[1], int(sys.argv[2])))
payload = b"\\0" * 65536
while True:
    conn.sendall(payload)
"""

needs_root = pytest.mark.testbed


class _Receiver:
    """Counts the payload of each connection accepted on a server in the leader side."""

    def __init__(self, channel: Channel) -> None:
        with ThreadPoolExecutor(1, initializer=enter, initargs=(channel.leader_ns,)) as pool:
            self.server = pool.submit(socket.create_server, (channel.leader_addr, 0)).result()
        self.port = self.server.getsockname()[1]
        self.received: dict[int, int] = {}  # by the sender's port

    def accept(self) -> int:
        conn, (_, port) = self.server.accept()
        self.received[port] = 0

        def drain() -> None:
            with conn:
                while data := conn.recv(65536):
                    self.received[port] += len(data)

        threading.Thread(target=drain, daemon=True).start()
        return int(port)

    def goodputs(self, channel: Channel) -> tuple[dict[int, float], int, int]:
        """Each connection's payload bits/s over WINDOW s after SETTLE s; the payload
        bytes received and the bytes the uplink's tbf sent over the window."""
        time.sleep(SETTLE)
        before, sent = dict(self.received), channel.uplink().sent_bytes
        time.sleep(WINDOW)
        after, sent = dict(self.received), channel.uplink().sent_bytes - sent
        rates = {port: (after[port] - before[port]) * 8 / WINDOW for port in after}
        return rates, sum(after.values()) - sum(before.values()), sent


@pytest.fixture
def two_senders() -> Iterator[tuple[Channel, _Receiver, list[tuple[int, int]]]]:
    """A channel, its receiver, and two sender processes as (pid, port)."""
    with Channel() as channel:
        receiver = _Receiver(channel)
        procs: list[subprocess.Popen[bytes]] = []
        senders = []
        try:
            for _ in range(2):  # one after the other: each port known to be its sender's
                procs.append(subprocess.Popen(
                    ["ip", "netns", "exec", channel.follower_ns, sys.executable, "-c",
                     SENDER, channel.leader_addr, str(receiver.port)]))
                senders.append((procs[-1].pid, receiver.accept()))
            yield channel, receiver, senders
        finally:
            for proc in procs:
                proc.kill()
                proc.wait()
            receiver.server.close()


def _show(what: str, rates: dict[int, float]) -> None:
    print(what, ", ".join(f"{rate / 1e6:.2f}" for rate in rates.values()), "Mbit/s")


@needs_root
def test_a_capped_process_gets_its_cap_and_the_other_the_rest(
        two_senders: tuple[Channel, _Receiver, list[tuple[int, int]]]) -> None:
    channel, receiver, [(slow, slow_port), (_, other_port)] = two_senders
    rates, _, _ = receiver.goodputs(channel)
    _show("both uncapped:", rates)
    assert min(rates.values()) > 0.25 * RATE  # they share it

    flows = channel.cap_flows_of(slow, CAP)
    assert [(dst, sport) for dst, sport, _ in flows] == [(channel.leader_addr, slow_port)]
    rates, payload, sent = receiver.goodputs(channel)
    _show(f"one capped at {CAP / 1e6:g}:", rates)
    assert 0.5 * CAP <= rates[slow_port] <= 1.3 * CAP
    assert rates[other_port] >= 0.8 * (RATE - CAP)
    assert payload <= sent <= 1.15 * payload  # the tbf still counts every byte
    capped = channel.cap_counters(slow)
    assert 0 < capped.sent_bytes < channel.uplink().sent_bytes
    assert f"process {slow}'s 1 flow(s) capped at" in channel.describe()

    channel.uncap(slow)
    rates, _, _ = receiver.goodputs(channel)
    _show("uncapped again:", rates)
    assert rates[slow_port] > 1.3 * CAP

    channel.set_rate(RATE // 2)  # the tbf still rules the whole uplink
    rates, _, _ = receiver.goodputs(channel)
    _show(f"at {RATE / 2e6:g} Mbit/s:", rates)
    assert 0.85 * RATE / 2 <= sum(rates.values()) <= 1.1 * RATE / 2


@needs_root
def test_capping_what_is_not_there_says_so_in_one_line() -> None:
    with Channel() as channel:
        gone = subprocess.Popen(["true"])
        gone.wait()
        for pid, rate, says in ((os.getpid(), CAP, "no TCP connection from the follower side"),
                                (gone.pid, CAP, f"no process {gone.pid}"),
                                (os.getpid(), 0, "a cap must be a whole number")):
            with pytest.raises(ValueError, match=says) as refused:
                channel.cap_flows_of(pid, rate)
            assert "\n" not in str(refused.value)
        with pytest.raises(ValueError, match="not capped"):
            channel.uncap(os.getpid())
