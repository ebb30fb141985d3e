"""How often a liveliness get comes back without a token that is there.

Why: the election (``transport/election.py``) asks which leaders' tokens are there. In
peer mode, eclipse-zenoh 1.10 sometimes answers without a token that a peer reaches
both directly (gossip) and through the router, most of all on a busy host; in client
mode every answer goes through the router. The election therefore takes the liveliness
subscriber, not the answers, as the authority. Run this again on a new Zenoh to see
whether that still has to be so.

A router, a holder of ``--tokens`` tokens (default 1) and an asker, each a process of
its own on loopback; the asker gets ``w/s/leaders/**`` for ``--seconds`` once it has
seen them all, and counts the answers that lack any. ``--busy K`` runs K busy loops
beside it. With many tokens (a leader's followers: ``--tokens 1000``), peer mode's
answers are short even on a quiet host, which is why the leader's discovery takes an
answer short of a token its watch holds as proving nothing gone (``token_table``).

    .venv/bin/python benchmarks/bench_liveliness_answers.py
    .venv/bin/python benchmarks/bench_liveliness_answers.py --busy 2 --modes peer client
    .venv/bin/python benchmarks/bench_liveliness_answers.py --tokens 1000 --interval 0.1
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.metadata
import multiprocessing
import subprocess
import sys
import time
from collections.abc import Iterator
from multiprocessing.synchronize import Event

import zenoh

from wiswarm_zenoh.transport.zenoh_config import SessionSpec, free_tcp_port

TOKENS = "w/s/leaders/older/{}"
REPLY_CAPACITY = 1 << 16  # a get's channel: Zenoh's default (256) deadlocks beyond it


def router(port: int, ready: Event, stop: Event) -> None:
    with zenoh.open(SessionSpec.loopback("router", listen_port=port).config()):
        ready.set()
        stop.wait()


def holder(port: int, mode: str, tokens: int, ready: Event, stop: Event) -> None:
    with zenoh.open(SessionSpec.loopback(mode, connect_ports=[port]).config()) as session:
        _tokens = [session.liveliness().declare_token(TOKENS.format(i))
                   for i in range(tokens)]
        ready.set()
        stop.wait()


def lacking_share(port: int, mode: str, tokens: int, seconds: float,
                  interval: float) -> tuple[int, int]:
    """(answers, answers lacking a token) over ``seconds`` from the first answer holding
    them all, one ask every ``interval`` seconds (a peer answers from its own tables in
    microseconds: asked back to back, the answers pile up in the moments that are
    right)."""
    with zenoh.open(SessionSpec.loopback(mode, connect_ports=[port]).config()) as session:
        liveliness = session.liveliness()

        def holds_token() -> bool:
            held = sum(reply.ok is not None for reply in liveliness.get(
                "w/s/leaders/**", zenoh.handlers.FifoChannel(REPLY_CAPACITY), timeout=2.0))
            return held == tokens

        deadline = time.monotonic() + 30
        while not holds_token():
            if time.monotonic() > deadline:
                raise RuntimeError("the token was never seen")
        answers = lacking = 0
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            answers += 1
            lacking += not holds_token()
            time.sleep(interval)
        return answers, lacking


@contextlib.contextmanager
def busy_loops(count: int) -> Iterator[None]:
    loops = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(count)]
    try:
        yield
    finally:
        for loop in loops:
            loop.kill()
            loop.wait()


def measure(mode: str, tokens: int, seconds: float, interval: float) -> tuple[int, int]:
    ctx = multiprocessing.get_context("spawn")
    port, stop = free_tcp_port(), ctx.Event()
    ready = [ctx.Event(), ctx.Event()]
    procs = [ctx.Process(target=router, args=(port, ready[0], stop))]
    procs[0].start()
    try:
        if not ready[0].wait(30):
            raise RuntimeError("the router did not start")
        procs.append(ctx.Process(target=holder, args=(port, mode, tokens, ready[1], stop)))
        procs[1].start()
        if not ready[1].wait(30):
            raise RuntimeError("the holder did not start")
        return lacking_share(port, mode, tokens, seconds, interval)
    finally:
        stop.set()
        for proc in procs:
            proc.join(30)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--modes", nargs="+", choices=["peer", "client"],
                        default=["peer", "client"], help="session modes of holder and asker")
    parser.add_argument("--seconds", type=float, default=4.0, help="asking time per run")
    parser.add_argument("--runs", type=int, default=2, help="runs per mode")
    parser.add_argument("--interval", type=float, default=0.002,
                        help="seconds between asks (default 0.002)")
    parser.add_argument("--busy", type=int, default=0, help="busy loops beside (default 0)")
    parser.add_argument("--tokens", type=int, default=1, help="tokens held (default 1)")
    args = parser.parse_args()
    print(f"eclipse-zenoh {importlib.metadata.version('eclipse-zenoh')}, "
          f"{args.busy} busy loops beside, {args.tokens} tokens, an ask every "
          f"{args.interval * 1e3:g} ms")
    with busy_loops(args.busy):
        for mode in args.modes:
            for run in range(args.runs):
                answers, lacking = measure(mode, args.tokens, args.seconds, args.interval)
                print(f"{mode:6s} run {run + 1}: {lacking} of {answers} answers lacked a "
                      f"token ({100 * lacking / answers:.1f} %)", flush=True)


if __name__ == "__main__":
    main()
