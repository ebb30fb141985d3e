"""What the testbed's records of what it built rely on, for channels and edge-cloud
topologies alike: who owns them (a process, by pid and start time, so that a reused
pid is not taken for the owner), one builder or remover at a time, and whether a
namespace is there."""

from __future__ import annotations

import contextlib
import fcntl
import logging
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TypeVar

from wiswarm_zenoh.testbed.netns import NETNS_DIR

log = logging.getLogger(__name__)
R = TypeVar("R")


def process_start(pid: int) -> int | None:
    """The start time of a live process (clock ticks; not a zombie), or None if gone."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = stat.rsplit(")", 1)[1].split()  # the name may hold spaces and parentheses
    return None if fields[0] in ("Z", "X") else int(fields[19])  # state, starttime


@contextlib.contextmanager
def locked(directory: Path) -> Iterator[None]:
    """Serialise building and removing across threads and processes (flock on a file
    in ``directory``, made if need be)."""
    directory.mkdir(mode=0o755, parents=True, exist_ok=True)
    with (directory / ".lock").open("a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        yield


def namespace_exists(ns: str) -> bool:
    return (NETNS_DIR / ns).exists()


def remove_orphans(kind: str, run_ids: Iterable[str], load: Callable[[str], R | None],
                   owned: Callable[[R], bool], owner: Callable[[R], int],
                   remove: Callable[[str, R | None], object]) -> list[str]:
    """Remove what each run id names unless its record says a live process owns it
    (a missing record: nobody does); logs each (WARNING) and returns their ids."""
    removed = []
    for run_id in run_ids:
        record = load(run_id)
        if record is not None and owned(record):
            continue
        remove(run_id, record)
        who = "unknown: no record" if record is None else f"pid {owner(record)}"
        log.warning("removed leftover %s %s (its process, %s, is gone)", kind, run_id, who)
        removed.append(run_id)
    return removed
