"""The relay's ends: EOF, resets, refusals, backpressure, stop, and its command line."""

from __future__ import annotations

import hashlib
import logging
import os
import re
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor

import pytest

from wiswarm_zenoh.testbed.relay import CHUNK, DEFAULT_MAX_LAG, DelayRelay
from wiswarm_zenoh.testbed.relay_cli import build_parser, main

from .relay_helpers import (
    DELAY,
    LOCAL,
    WAIT,
    drain,
    recv_exact,
    relayed,
    send_and_close,
)

pytestmark = pytest.mark.usefixtures("no_relay_thread_left")


def test_eof_crosses_after_the_delay_and_the_other_half_stays_open() -> None:
    with relayed(DELAY) as (relay, client, end):
        closed = time.monotonic()
        send_and_close(client, b"ping")
        assert recv_exact(end, 4) == b"ping"
        assert end.recv(1) == b""
        assert time.monotonic() - closed >= DELAY
        end.sendall(b"pong")  # the half-closed connection still carries the other way
        end.shutdown(socket.SHUT_WR)
        assert recv_exact(client, 4) == b"pong"
        assert client.recv(1) == b""
        assert relay.wait_idle(WAIT)


def test_a_reset_crosses_after_the_delay() -> None:
    with relayed(DELAY) as (relay, client, end):
        client.sendall(b"!")
        assert end.recv(1) == b"!"  # the relay has reached the target: it relays
        end.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        reset = time.monotonic()
        end.close()
        with pytest.raises(ConnectionResetError):
            client.recv(1)
        assert time.monotonic() - reset >= DELAY
        assert relay.wait_idle(WAIT)


def test_a_target_that_refuses_closes_the_client_and_is_logged(
        caplog: pytest.LogCaptureFixture) -> None:
    with socket.create_server((LOCAL, 0)) as closed:
        refusing = closed.getsockname()  # nothing listens there once it is closed
    caplog.set_level(logging.WARNING, logger="wiswarm_zenoh.testbed.relay")
    with DelayRelay((LOCAL, 0), refusing, DELAY) as relay, socket.socket() as client:
        client.settimeout(WAIT)
        client.bind((LOCAL, 0))
        source = f"{LOCAL}:{client.getsockname()[1]}"
        # reset at once: on a busy machine, before ``connect`` has even returned
        with pytest.raises(ConnectionResetError):
            client.connect((LOCAL, relay.port))
            client.recv(1)
        counters = relay.counters()
    assert (counters.connections, counters.unreachable, counters.active) == (1, 1, 0)
    (record,) = caplog.records
    message = record.getMessage()
    assert "cannot reach the target" in message
    assert f"{LOCAL}:{refusing[1]}" in message and source in message


def _send_until_stalled(client: socket.socket, payload: bytes, pool: ThreadPoolExecutor
                        ) -> Future[None]:
    """Send ``payload`` then EOF on a thread; return once no byte could be sent for 0.5 s
    (the relay reads no more) or it is all sent."""
    blocked = threading.Event()
    client.settimeout(0.5)

    def send() -> None:
        view, sent = memoryview(payload), 0
        while sent < len(payload):
            try:
                sent += client.send(view[sent:sent + CHUNK])
            except TimeoutError:
                blocked.set()
        client.shutdown(socket.SHUT_WR)

    sending = pool.submit(send)
    sending.add_done_callback(lambda _: blocked.set())
    assert blocked.wait(WAIT)
    return sending


@pytest.mark.parametrize(("max_held", "max_lag", "most_held"), [
    (2 * 1024 * 1024, float("inf"), 2 * 1024 * 1024 + CHUNK),  # the bound stops reading
    (64 * 1024 * 1024, DEFAULT_MAX_LAG, 16 * 1024 * 1024)],  # the blocked writer does
    ids=["max_held", "max_lag"])
def test_a_stalled_target_pushes_back_on_the_sender(max_held: int, max_lag: float,
                                                    most_held: int) -> None:
    """The target stops reading: the relay soon stops too (the sender blocks), holding
    little; once the target reads again, every byte arrives intact."""
    payload = os.urandom(80 * 1024 * 1024)  # more than every buffer on the way
    with (relayed(0.002, max_held, max_lag, rcvbuf=64 * 1024) as (relay, client, end),
          ThreadPoolExecutor(1) as pool):
        sending = _send_until_stalled(client, payload, pool)
        stalled = relay.counters()
        got = drain(end)
        sending.result(WAIT)
    print(f"stalled after {stalled.to_target_bytes / 1e6:.1f} MB relayed, peak held "
          f"{stalled.peak_held_bytes / 1e6:.2f} MB")
    assert stalled.to_target_bytes < len(payload) / 2
    assert stalled.peak_held_bytes <= most_held
    assert got == (len(payload), hashlib.sha256(payload).hexdigest())


def test_stop_resets_open_connections_even_with_a_write_blocked() -> None:
    with (relayed(0.002, rcvbuf=64 * 1024) as (relay, client, end),
          ThreadPoolExecutor(1) as pool):
        sending = _send_until_stalled(client, bytes(80 * 1024 * 1024), pool)
        assert not sending.done()  # the relay's writer to the target is blocked too
        stopper = threading.Thread(target=relay.stop, daemon=True)
        stopper.start()
        stopper.join(WAIT)
        assert not stopper.is_alive()
        with pytest.raises(ConnectionResetError):
            sending.result(WAIT)
        with pytest.raises(ConnectionResetError):
            drain(end)
        assert relay.counters().active == 0


@pytest.mark.parametrize("kwargs", [
    {"delay": -0.001}, {"delay": float("nan")}, {"delay": float("inf")},
    {"delay": 0.02, "delay_back": -1.0}, {"delay": 0.02, "max_held": 0},
    {"delay": 0.02, "max_lag": float("nan")}])
def test_a_bad_setting_is_refused(kwargs: dict[str, float]) -> None:
    with pytest.raises(ValueError, match="need finite delays"):
        DelayRelay((LOCAL, 0), (LOCAL, 1), **kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize(("flag", "value"), [
    ("--delay", "x"), ("--delay", "0"), ("--delay", "nan"), ("--target", "127.0.0.1:0"),
    ("--listen", "127.0.0.1:99999"), ("--listen", "[::1"), ("--delay-back", "-1ms")])
def test_a_bad_flag_is_one_line_and_exit_2(flag: str, value: str,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    argv = {"--listen": "127.0.0.1:0", "--target": "127.0.0.1:7447", "--delay": "20ms",
            flag: value}
    assert main([part for item in argv.items() for part in item]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and "error:" in lines[0] and flag in lines[0]


def test_delays_are_read_like_tc_and_a_busy_port_is_one_line(
        capsys: pytest.CaptureFixture[str]) -> None:
    for text in ("20ms", "0.02", "20000us"):
        args = build_parser().parse_args(
            ["--listen", "127.0.0.1:0", "--target", "127.0.0.1:1", "--delay", text])
        assert args.delay == pytest.approx(0.02)
    with socket.create_server((LOCAL, 0)) as busy:
        port = busy.getsockname()[1]
        assert main(["--listen", f"{LOCAL}:{port}", "--target", f"{LOCAL}:1",
                     "--delay", "1ms"]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and f"cannot listen on {LOCAL}:{port}" in lines[0]


def test_the_command_relays_until_sigterm() -> None:
    with socket.create_server((LOCAL, 0)) as server:
        server.settimeout(WAIT)
        target = f"{LOCAL}:{server.getsockname()[1]}"
        process = subprocess.Popen(
            [sys.executable, "-m", "wiswarm_zenoh.testbed.relay", "--listen", f"{LOCAL}:0",
             "--target", target, "--delay", "10ms"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            assert process.stdout is not None
            first = process.stdout.readline()
            found = re.search(rf"listening on {LOCAL}:(\d+), relaying to {target} 10 ms late "
                              "there, 10 ms back", first)
            assert found, first
            with socket.create_connection((LOCAL, int(found.group(1))), WAIT) as client:
                client.sendall(b"hello")
                end, _ = server.accept()
                with end:
                    end.settimeout(WAIT)
                    assert recv_exact(end, 5) == b"hello"
            process.send_signal(signal.SIGTERM)
            _, err = process.communicate(timeout=WAIT)
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()
    assert process.returncode == 0
    assert "relayed 5 bytes to the target and 0 back over 1 connections" in err
