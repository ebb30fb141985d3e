"""The WiFi media's records and leftovers: each medium's namespaces are named after its
run id, its record (owner, scenario process), stats lines and scenario log live under
``/run/wiswarm-testbed/wifi`` (not beside the tbf channels' records, which ``channel``
prunes), so the next build removes a medium whose owner died (SIGKILL) and stops its
scenario."""

from __future__ import annotations

import json
import logging
import os
import select
import signal
from pathlib import Path
from typing import Any

from wiswarm_zenoh.testbed.channel_records import STATE_DIR
from wiswarm_zenoh.testbed.netns import NETNS_DIR
from wiswarm_zenoh.testbed.ownership import (
    locked,
    namespace_exists,
    process_start,
    remove_orphans,
)
from wiswarm_zenoh.testbed.tc import run

log = logging.getLogger("wiswarm_zenoh.testbed.wifi")

RECORDS = STATE_DIR / "wifi"
NS_PREFIX = "wsw28-"  # not "wsw-": the tbf channels' cleanup owns that prefix
STOP_TIMEOUT = 5.0


def ns_name(run_id: str, node: int) -> str:
    return f"{NS_PREFIX}{run_id}-{'ap' if node == 0 else f's{node}'}"


def record_paths(run_id: str) -> tuple[Path, Path, Path]:
    """Record, stats lines, scenario's stderr."""
    return (RECORDS / f"{run_id}.json", RECORDS / f"{run_id}.stats",
            RECORDS / f"{run_id}.log")


def load_record(run_id: str) -> dict[str, Any] | None:
    try:
        data: dict[str, Any] = json.loads(record_paths(run_id)[0].read_text())
        return data
    except (OSError, ValueError) as exc:
        log.debug("no usable record of WiFi medium %s: %s", run_id, exc)
        return None


def save_record(record: dict[str, Any]) -> None:
    path = record_paths(str(record["run_id"]))[0]
    temporary = path.with_suffix(".tmp")
    temporary.write_text(json.dumps(record, indent=1) + "\n")
    os.replace(temporary, path)


def list_media() -> list[str]:
    """Run ids of every medium present (its access point's namespace)."""
    try:
        names = os.listdir(NETNS_DIR)
    except FileNotFoundError:
        return []
    return sorted(name[len(NS_PREFIX):-len("-ap")] for name in names
                  if name.startswith(NS_PREFIX) and name.endswith("-ap"))


def stop_scenario(record: dict[str, Any]) -> None:
    """SIGTERM the scenario if it is still the process the record names, then SIGKILL."""
    pid, start = int(record.get("scenario_pid", 0)), record.get("scenario_start")
    if pid <= 0 or process_start(pid) != start:
        return
    try:
        handle = os.pidfd_open(pid)  # readable once the process has ended
    except ProcessLookupError:
        return  # it ended meanwhile
    try:
        os.kill(pid, signal.SIGTERM)
        if not select.select([handle], [], [], STOP_TIMEOUT)[0]:
            os.kill(pid, signal.SIGKILL)
    finally:
        os.close(handle)


def remove_locked(run_id: str, record: dict[str, Any] | None) -> bool:
    if record is not None:
        stop_scenario(record)
    present = [ns for ns in (f"{NS_PREFIX}{run_id}-{name}" for name in _node_names(run_id))
               if namespace_exists(ns)]
    for ns in present:
        run("ip", "netns", "del", ns)  # takes its tap along
    left = [ns for ns in present if namespace_exists(ns)]
    if left:
        raise RuntimeError(f"network namespaces {', '.join(left)} are still present")
    for path in record_paths(run_id):
        path.unlink(missing_ok=True)
    return bool(present)


def _node_names(run_id: str) -> list[str]:
    prefix = f"{NS_PREFIX}{run_id}-"
    try:
        names = os.listdir(NETNS_DIR)
    except FileNotFoundError:
        return []
    return [name[len(prefix):] for name in names if name.startswith(prefix)
            and (name[len(prefix):] == "ap" or name[len(prefix):].lstrip("s").isdigit())]


def _owned(record: dict[str, Any]) -> bool:
    return (int(record["owner_pid"]) == 0
            or process_start(int(record["owner_pid"])) == record["owner_start"])


def cleanup_locked() -> list[str]:
    recorded = {path.stem for path in RECORDS.glob("*.json")}
    return remove_orphans("WiFi medium", sorted(set(list_media()) | recorded), load_record, _owned,
                          lambda record: int(record["owner_pid"]), remove_locked)


def cleanup_leftovers() -> list[str]:
    """Remove media whose creating process is gone (and stop their scenarios)."""
    with locked(RECORDS):
        return cleanup_locked()


def remove_medium(run_id: str) -> None:
    """Remove medium ``run_id`` whoever made it; LookupError if there is none."""
    with locked(RECORDS):
        if not remove_locked(run_id, load_record(run_id)):
            raise LookupError(f"no WiFi medium {run_id!r}")
    log.info("removed WiFi medium %s", run_id)
