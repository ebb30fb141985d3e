"""What a poll costs the machine, not only Python (issue 44): per poll, the context
switches of each process and of each thread (voluntary: the thread slept, on a lock, a
futex, a socket; involuntary: it was preempted) and their user and system CPU, read
from ``/proc/<pid>/task/*`` over windows of polls. A second hand-over per poll shows as
a voluntary switch more per poll, whatever the machine's speed, so two machines' runs
compare where their polls/s do not.

This process's total comes from ``getrusage``, which keeps the counts of threads that
ended within the window; its threads are named as Python names them (``threading``'s
native ids), other processes' threads by their kernel name, digits folded
(``rx-0``, ``rx-1``: ``rx-#``).
"""

from __future__ import annotations

import os
import re
import resource
import threading
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

TICKS = os.sysconf("SC_CLK_TCK")
SELF = "this process"


@dataclass(frozen=True)
class Usage:
    """Context switches and CPU seconds of a thread or a process."""

    voluntary: int = 0
    involuntary: int = 0
    user_s: float = 0.0
    system_s: float = 0.0

    def __add__(self, other: Usage) -> Usage:
        return Usage(self.voluntary + other.voluntary, self.involuntary + other.involuntary,
                     self.user_s + other.user_s, self.system_s + other.system_s)

    def __sub__(self, other: Usage) -> Usage:
        return Usage(self.voluntary - other.voluntary, self.involuntary - other.involuntary,
                     self.user_s - other.user_s, self.system_s - other.system_s)

    def per_poll(self, polls: int) -> str:
        n = max(polls, 1)
        return (f"{self.voluntary / n:5.2f} vol {self.involuntary / n:5.2f} invol "
                f"{self.user_s / n * 1e6:6.1f} us user {self.system_s / n * 1e6:6.1f} us sys")


def task_usage(task: Path) -> Usage:
    """One thread's usage from its ``status`` and ``stat``."""
    counts = {}
    for line in (task / "status").read_text().splitlines():
        key, _, value = line.partition(":")
        if key in ("voluntary_ctxt_switches", "nonvoluntary_ctxt_switches"):
            counts[key] = int(value)
    fields = (task / "stat").read_text().rsplit(")", 1)[1].split()
    return Usage(counts["voluntary_ctxt_switches"], counts["nonvoluntary_ctxt_switches"],
                 int(fields[11]) / TICKS, int(fields[12]) / TICKS)


def thread_usages(pid: int) -> dict[int, tuple[str, Usage]]:
    """Every live thread of ``pid``: (name, usage) by thread id; a thread that ends while
    it is read is left out."""
    python = {t.native_id: t.name for t in threading.enumerate()} if pid == os.getpid() else {}
    found = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        tid = int(task.name)
        try:
            name = python.get(tid) or re.sub(r"\d+", "#", (task / "comm").read_text().strip())
            found[tid] = (name, task_usage(task))
        except (FileNotFoundError, ProcessLookupError, KeyError):
            continue
    return found


def self_usage() -> Usage:
    own = resource.getrusage(resource.RUSAGE_SELF)
    return Usage(own.ru_nvcsw, own.ru_nivcsw, own.ru_utime, own.ru_stime)


def process_usage(pid: int) -> Usage:
    if pid == os.getpid():
        return self_usage()
    total = Usage()
    for _, usage in thread_usages(pid).values():
        total += usage
    return total


class MachineCost:
    """Sums, over windows of polls (``begin``, ``end(polls)``), the usage of this
    process and of ``others`` (role: pid), and of each thread of this process."""

    def __init__(self, others: dict[str, int] | None = None) -> None:
        self._pids = {SELF: os.getpid(), **(others or {})}
        self.polls = 0
        self.processes: dict[str, Usage] = defaultdict(Usage)
        self.threads: dict[str, Usage] = defaultdict(Usage)
        self._start: tuple[dict[str, Usage], dict[int, tuple[str, Usage]]] | None = None

    def begin(self) -> None:
        self._start = ({role: process_usage(pid) for role, pid in self._pids.items()},
                       thread_usages(os.getpid()))

    def end(self, polls: int) -> None:
        if self._start is None:
            raise RuntimeError("end() without begin()")
        processes, threads = self._start
        self._start = None
        for role, pid in self._pids.items():
            self.processes[role] += process_usage(pid) - processes[role]
        for tid, (name, usage) in thread_usages(os.getpid()).items():
            before = threads.get(tid)
            self.threads[name] += usage - (before[1] if before else Usage())
        self.polls += polls

    def lines(self, label: str, top: int = 6) -> list[str]:
        """Per poll: each process, then this process's busiest threads."""
        out = [f"  machine per poll, {label} ({self.polls} polls):"]
        for role, usage in self.processes.items():
            out.append(f"    {role:32} {usage.per_poll(self.polls)}")
        busiest = sorted(self.threads.items(), key=lambda item: -item[1].voluntary)[:top]
        for name, usage in busiest:
            out.append(f"      thread {name[:25]:25} {usage.per_poll(self.polls)}")
        return out
