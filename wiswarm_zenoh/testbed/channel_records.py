"""The tbf channels' records and leftovers: each channel's two namespaces
(``wsw-<id>-L``/``-F``) and its record under ``/run/wiswarm-testbed`` naming the
process that owns it, so that a channel whose owner died (SIGKILL) is found and removed
by the next build or ``wiswarm testbed cleanup``."""

from __future__ import annotations

import json
import logging
import os
from dataclasses import asdict, dataclass
from pathlib import Path

from wiswarm_zenoh.testbed.netns import NETNS_DIR
from wiswarm_zenoh.testbed.ownership import (
    locked,
    namespace_exists,
    process_start,
    remove_orphans,
)
from wiswarm_zenoh.testbed.spec import ChannelSpec
from wiswarm_zenoh.testbed.tc import run, run_json

log = logging.getLogger("wiswarm_zenoh.testbed.channel")

NS_PREFIX = "wsw-"
LEADER_SUFFIX = "-L"
FOLLOWER_SUFFIX = "-F"
# Each end lives in its own namespace from creation on, so fixed names never collide.
LEADER_IF = "wsw-L"
FOLLOWER_IF = "wsw-F"
STATE_DIR = Path("/run/wiswarm-testbed")


@dataclass(frozen=True)
class ChannelRecord:
    """What ``/run/wiswarm-testbed/<run_id>.json`` keeps: owner, addresses, spec as set."""

    run_id: str
    owner_pid: int  # 0 for a persistent channel
    owner_start: int  # the owner's start time (clock ticks), against pid reuse
    subnet: int
    spec: ChannelSpec

    @property
    def persistent(self) -> bool:
        return self.owner_pid == 0

    def save(self) -> None:
        data = {"run_id": self.run_id, "owner_pid": self.owner_pid,
                "owner_start": self.owner_start, "persistent": self.persistent,
                "subnet": self.subnet, "spec": asdict(self.spec)}
        path = record_path(self.run_id)
        temporary = path.with_suffix(".tmp")
        temporary.write_text(json.dumps(data, indent=1) + "\n")
        os.replace(temporary, path)

    @classmethod
    def load(cls, run_id: str) -> ChannelRecord | None:
        """The record, or None if missing or unreadable (the channel is then unowned)."""
        try:
            data = json.loads(record_path(run_id).read_text())
            return cls(run_id, int(data["owner_pid"]), int(data["owner_start"]),
                       int(data["subnet"]), ChannelSpec(**data["spec"]))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            log.debug("no usable record of testbed channel %s: %s", run_id, exc)
            return None


def record_path(run_id: str) -> Path:
    return STATE_DIR / f"{run_id}.json"


def namespaces(run_id: str) -> tuple[str, str]:
    return f"{NS_PREFIX}{run_id}{LEADER_SUFFIX}", f"{NS_PREFIX}{run_id}{FOLLOWER_SUFFIX}"


def links(ns: str) -> set[str]:
    return {link["ifname"] for link in run_json("ip", "-n", ns, "-j", "link", "show")}


def _owned_by_live_process(record: ChannelRecord) -> bool:
    return record.persistent or process_start(record.owner_pid) == record.owner_start


def list_channels() -> list[str]:
    """Run ids of every channel present (either namespace ``wsw-<id>-L``/``-F``)."""
    try:
        names = os.listdir(NETNS_DIR)
    except FileNotFoundError:
        return []
    least = len(NS_PREFIX) + len(LEADER_SUFFIX)
    return sorted({name[len(NS_PREFIX):-len(LEADER_SUFFIX)] for name in names
                   if name.startswith(NS_PREFIX) and len(name) > least
                   and name.endswith((LEADER_SUFFIX, FOLLOWER_SUFFIX))})


def remove_locked(run_id: str) -> bool:
    """Remove the veth (both ends, with their qdiscs), the namespaces and the record, and
    verify; True if there was a channel to remove."""
    pairs = tuple(zip(namespaces(run_id), (LEADER_IF, FOLLOWER_IF), strict=True))
    present = [(ns, ifname) for ns, ifname in pairs if namespace_exists(ns)]
    for ns, ifname in present:
        if ifname in links(ns):
            run("ip", "-n", ns, "link", "del", "dev", ifname)  # takes its peer along
    for ns, ifname in present:
        if ifname in links(ns):
            raise RuntimeError(f"{ifname} is still in namespace {ns} after deleting it")
        run("ip", "netns", "del", ns)
    left = [ns for ns, _ in pairs if namespace_exists(ns)]
    if left:
        raise RuntimeError(f"network namespaces {', '.join(left)} are still present")
    record_path(run_id).unlink(missing_ok=True)
    return bool(present)


def remove_channel(run_id: str) -> None:
    """Remove channel ``run_id`` whoever made it; LookupError if there is none."""
    with locked(STATE_DIR):
        if not remove_locked(run_id):
            raise LookupError(f"no testbed channel {run_id!r}")
    log.info("removed testbed channel %s", run_id)


def cleanup_locked() -> list[str]:
    present = set(list_channels())
    recorded = {path.stem for path in STATE_DIR.glob("*.json")}
    for run_id in sorted(recorded - present):
        record_path(run_id).unlink(missing_ok=True)  # removed behind its owner's back
    return remove_orphans("testbed channel", sorted(present), ChannelRecord.load,
                          _owned_by_live_process, lambda record: record.owner_pid,
                          lambda run_id, _: remove_locked(run_id))


def cleanup_leftovers() -> list[str]:
    """Remove channels whose creating process is gone; returns their run ids."""
    with locked(STATE_DIR):
        return cleanup_locked()
