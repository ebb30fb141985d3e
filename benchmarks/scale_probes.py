"""What the leader of ``bench_scale.py`` costs, read in its own process: resident memory,
CPU time (the process's, some threads', the whole machine's, from ``/proc``) and the
garbage collector's pauses. Kept apart from the run so that the run reads as steps."""

from __future__ import annotations

import gc
import os
import time

TICKS = os.sysconf("SC_CLK_TCK")


def rss_bytes() -> int:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    raise RuntimeError("no VmRSS in /proc/self/status")


def thread_cpu(native_ids: list[int]) -> float:
    """CPU seconds of some threads of this process (user + system)."""
    total = 0
    for native_id in native_ids:
        with open(f"/proc/self/task/{native_id}/stat") as stat:
            fields = stat.read().rsplit(")", 1)[1].split()
        total += int(fields[11]) + int(fields[12])
    return total / TICKS


def machine_busy() -> float:
    """CPU seconds every core of the machine has spent busy so far (all processes)."""
    with open("/proc/stat") as stat:
        fields = [int(x) for x in stat.readline().split()[1:]]
    return (sum(fields) - fields[3] - fields[4]) / TICKS  # all but idle and iowait


def process_cpu() -> float:
    times = os.times()
    return times.user + times.system


class Pauses:
    """The garbage collector's pauses in this process (a pause of the poll thread's
    interpreter holds every reply back: a long one makes polls time out)."""

    def __init__(self) -> None:
        self.longest = [0.0, 0.0, 0.0]  # per generation, seconds
        self.count = [0, 0, 0]
        self._started = 0.0
        gc.callbacks.append(self._on_gc)

    def _on_gc(self, phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            self._started = time.perf_counter()
            return
        generation = info["generation"]
        self.count[generation] += 1
        self.longest[generation] = max(self.longest[generation],
                                       time.perf_counter() - self._started)

    def close(self) -> None:
        gc.callbacks.remove(self._on_gc)
