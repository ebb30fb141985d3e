"""The ``ip``/``tc`` commands a channel is built, read and changed with."""

from __future__ import annotations

import json
import logging
import signal
import subprocess
from dataclasses import replace
from typing import Any

from wiswarm_zenoh.testbed.spec import ChannelSpec, LinkCounters

log = logging.getLogger(__name__)


def run(*argv: str) -> str:
    """Run ``ip``/``tc``; RuntimeError with its stderr if it fails. In a session of its
    own: a Ctrl-C at the terminal reaches the whole process group, and must not kill the
    commands that remove a channel while a run winds down. One that reached it all the
    same (between its fork and its new session: a wide moment on a busy machine) was
    meant for this process, which has it too: the command runs again."""
    for _ in range(2):
        done = subprocess.run(argv, capture_output=True, text=True, check=False,
                              start_new_session=True)
        if done.returncode != -signal.SIGINT:
            break
    if done.returncode != 0:
        raise RuntimeError(f"`{' '.join(argv)}` failed (exit {done.returncode}): "
                           f"{done.stderr.strip() or 'no message'}")
    if done.stderr.strip():
        log.warning("`%s`: %s", " ".join(argv), done.stderr.strip())
    return done.stdout


def run_json(*argv: str) -> list[dict[str, Any]]:
    result: list[dict[str, Any]] = json.loads(run(*argv) or "[]")
    return result


def tbf_qdisc(ns: str, ifname: str) -> dict[str, Any]:
    """The root tbf qdisc of ``ifname`` as ``tc -s -j`` reports it."""
    for qdisc in run_json("tc", "-n", ns, "-s", "-j", "qdisc", "show", "dev", ifname):
        if qdisc.get("kind") == "tbf" and qdisc.get("root"):
            return qdisc
    raise RuntimeError(f"no tbf qdisc on {ifname} in namespace {ns}")


def tbf_args(rate_bps: int, spec: ChannelSpec) -> tuple[str, ...]:
    return ("tbf", "rate", f"{rate_bps}bit", "burst", str(spec.burst_bytes),
            "latency", f"{round(spec.queue_s * 1e6)}us")


def _prefer(measured: float, recorded: float, slack: float) -> float:
    """The recorded value where tc's reading differs from it by its rounding only."""
    return recorded if abs(measured - recorded) <= slack else measured


def spec_from_tc(up: dict[str, Any], down: dict[str, Any],
                  recorded: ChannelSpec | None) -> ChannelSpec:
    """The spec tc reports (bytes/s and microseconds), in the record's exact values where
    only tc's rounding differs, so that a spec read back equals the one set."""
    rate, down_rate = up["rate"] * 8, down["rate"] * 8
    burst, queue = up["burst"], up["lat"] / 1e6
    if recorded is not None:
        rate = int(_prefer(rate, recorded.rate_bps, 8))
        down_rate = int(_prefer(down_rate, recorded.down_bps, 8))
        burst = int(_prefer(burst, recorded.burst_bytes,
                            max(rate, down_rate) / 8 * 2e-6 + 0.01 * recorded.burst_bytes))
        queue = _prefer(queue, recorded.queue_s, 0.01 * recorded.queue_s + 2e-6)
        if (rate, down_rate) == (recorded.rate_bps, recorded.down_bps):
            return replace(recorded, burst_bytes=burst, queue_s=queue)
    return ChannelSpec(rate, queue, None if down_rate == rate else down_rate, burst)


def counters(ns: str, ifname: str) -> LinkCounters:
    tbf = tbf_qdisc(ns, ifname)
    return LinkCounters(sent_bytes=tbf["bytes"], sent_packets=tbf["packets"],
                        dropped=tbf["drops"], overlimits=tbf["overlimits"],
                        backlog_bytes=tbf["backlog"])
