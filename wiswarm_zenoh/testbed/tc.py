"""The ``ip``/``tc`` commands a channel is built, read and changed with."""

from __future__ import annotations

import json
import logging
import signal
import subprocess
from dataclasses import replace
from typing import Any

from wiswarm_zenoh.testbed.spec import MAX_FRAME_BYTES, ChannelSpec, LinkCounters
from wiswarm_zenoh.units import MAX_RATE_BPS

log = logging.getLogger(__name__)

HTB = 0x10  # the htb's major number, under the root tbf once a flow is capped
UNCAPPED = 1  # its default class: every flow not capped, shaped by the tbf alone


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


def _counters(qdisc: dict[str, Any]) -> LinkCounters:
    return LinkCounters(sent_bytes=qdisc["bytes"], sent_packets=qdisc["packets"],
                        dropped=qdisc["drops"], overlimits=qdisc["overlimits"],
                        backlog_bytes=qdisc["backlog"])


def counters(ns: str, ifname: str) -> LinkCounters:
    """The root tbf's: every byte of the direction, capped flows' too."""
    return _counters(tbf_qdisc(ns, ifname))


def _leaf(k: int) -> str:
    return f"{0x100 + k:x}:"


def add_htb(ns: str, ifname: str, spec: ChannelSpec, rate_bps: int) -> None:
    """An htb as the root tbf's one child, for flows to be capped in classes of their
    own; everything else in its default class, at no rate of its own (the tbf's rate
    rules) and with the tbf's queue limit (``set_queue``), so nothing changes for it."""
    tbf = tbf_qdisc(ns, ifname)["handle"]
    run("tc", "-n", ns, "qdisc", "replace", "dev", ifname, "parent", f"{tbf}1",
        "handle", f"{HTB:x}:", "htb", "default", f"{UNCAPPED:x}")
    set_class(ns, ifname, UNCAPPED, MAX_RATE_BPS, spec.limit_bytes(rate_bps), spec)


def set_class(ns: str, ifname: str, k: int, rate_bps: int, limit_bytes: int,
              spec: ChannelSpec) -> None:
    """Class ``k`` of the htb at ``rate_bps`` (its ceiling too: it never borrows), made
    or changed, with a byte FIFO of ``limit_bytes`` (tbf's limit: rate * latency +
    burst); its queued packets stay queued. Quantum one frame: when both the default
    class and a capped one under its rate have packets, they take turns frame by frame."""
    run("tc", "-n", ns, "class", "replace", "dev", ifname, "parent", f"{HTB:x}:",
        "classid", f"{HTB:x}:{k:x}", "htb", "rate", f"{rate_bps}bit", "ceil",
        f"{rate_bps}bit", "burst", str(spec.burst_bytes), "cburst", str(spec.burst_bytes),
        "quantum", str(MAX_FRAME_BYTES))
    set_queue(ns, ifname, k, limit_bytes)


def set_queue(ns: str, ifname: str, k: int, limit_bytes: int) -> None:
    run("tc", "-n", ns, "qdisc", "replace", "dev", ifname, "parent", f"{HTB:x}:{k:x}",
        "handle", _leaf(k), "bfifo", "limit", str(limit_bytes))


def steer(ns: str, ifname: str, k: int, flows: list[tuple[str, int, int]]) -> None:
    """TCP packets of ``flows`` (destination address, source port, destination port)
    into class ``k``, by filters of their own priority (``unsteer`` removes them)."""
    for dst, sport, dport in flows:
        run("tc", "-n", ns, "filter", "add", "dev", ifname, "parent", f"{HTB:x}:",
            "protocol", "ip", "prio", str(k), "u32", "match", "ip", "protocol", "6", "0xff",
            "match", "ip", "dst", f"{dst}/32", "match", "ip", "sport", str(sport), "0xffff",
            "match", "ip", "dport", str(dport), "0xffff", "flowid", f"{HTB:x}:{k:x}")


def unsteer(ns: str, ifname: str, k: int) -> None:
    """Class ``k``'s filters removed: its flows back in the default class."""
    run("tc", "-n", ns, "filter", "del", "dev", ifname, "parent", f"{HTB:x}:",
        "prio", str(k))


def remove_class(ns: str, ifname: str, k: int) -> None:
    """Class ``k`` and its queue (packets still in it lost), once ``unsteer``ed."""
    run("tc", "-n", ns, "class", "del", "dev", ifname, "classid", f"{HTB:x}:{k:x}")


def class_counters(ns: str, ifname: str, k: int) -> LinkCounters:
    """Class ``k``'s queue's (a FIFO: its overlimits are always 0)."""
    for qdisc in run_json("tc", "-n", ns, "-s", "-j", "qdisc", "show", "dev", ifname):
        if qdisc.get("handle") == _leaf(k):
            return _counters(qdisc)
    raise RuntimeError(f"no queue of class {HTB:x}:{k:x} on {ifname} in namespace {ns}")
