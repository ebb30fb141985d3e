"""What a run shows and leaves behind: the live table, the stats CSV, the AoI plot."""

from __future__ import annotations

import csv
import sys
import time
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TextIO

from wiswarm_zenoh.core.members import robot_of

Record = Mapping[str, object]

STATS_COLUMNS = ("time_s", "follower", "aoi_s", "mean_aoi_s", "p95_aoi_s", "p_hat", "weight",
                 "polls", "deliveries", "timeouts", "errors")
PLAIN_EVERY = 5.0  # seconds between tables when the output is not a terminal


def _num(record: Record, key: str) -> float:
    value = record.get(key, 0.0)
    return float(value) if isinstance(value, int | float) else 0.0


def format_table(records: Sequence[Record], polls_per_s: Mapping[str, float],
                 header: str = "") -> list[str]:
    """One line per follower: AoI now, mean, p95 (ms), p_hat, weight, polls/s; a robot's
    streams (``uav1~camera``, ``uav1~odometry``) together, under their robot."""
    lines = [header] if header else []
    lines.append(f"{'follower':>10} {'AoI ms':>9} {'mean ms':>9} {'p95 ms':>9} "
                 f"{'p_hat':>6} {'weight':>7} {'polls/s':>8} {'errors':>7}")
    def by_robot(record: Record) -> tuple[str, str]:
        name = str(record.get("follower"))
        return robot_of(name), name

    for record in sorted(records, key=by_robot):
        name = str(record.get("follower"))
        lines.append(
            f"{name:>10} {_num(record, 'aoi_s') * 1e3:9.1f} {_num(record, 'mean_aoi_s') * 1e3:9.2f}"
            f" {_num(record, 'p95_aoi_s') * 1e3:9.2f} {_num(record, 'p_hat'):6.2f}"
            f" {_num(record, 'weight'):7.2f} {polls_per_s.get(name, 0.0):8.1f}"
            f" {int(_num(record, 'errors')):7d}"
        )
    return lines


class LiveTable:
    """Redraws a block of lines in place on a terminal (ANSI cursor moves); elsewhere
    (a log, a pipe) prints a block only every PLAIN_EVERY seconds."""

    def __init__(self, stream: TextIO = sys.stdout) -> None:
        self._stream = stream
        self._tty = stream.isatty()
        self._drawn = 0
        self._last_plain = 0.0

    def show(self, lines: Sequence[str]) -> None:
        """Draw ``lines`` in place of the block drawn before."""
        if self._tty:
            up = f"\x1b[{self._drawn}F" if self._drawn else ""
            body = "".join(f"\x1b[2K{line}\n" for line in lines)
            self._stream.write(up + body)
            self._drawn = len(lines)
        elif time.monotonic() - self._last_plain >= PLAIN_EVERY:
            self._stream.write("\n".join(lines) + "\n")
            self._last_plain = time.monotonic()
        self._stream.flush()


class PollRates:
    """Polls per second of each follower, from the ``polls`` counters of its stats."""

    def __init__(self) -> None:
        self._last: dict[str, tuple[float, float]] = {}
        self.rates: dict[str, float] = {}

    def observe(self, follower: str, polls: float, now: float) -> None:
        last = self._last.get(follower)
        if last is not None and now - last[0] >= 0.2:
            self.rates[follower] = max(0.0, polls - last[1]) / (now - last[0])
        if last is None or now - last[0] >= 0.2:
            self._last[follower] = (now, polls)


def write_stats_csv(path: Path, rows: Iterable[Record]) -> None:
    with path.open("w", newline="") as out:
        writer = csv.DictWriter(out, fieldnames=STATS_COLUMNS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)


def read_deliveries(path: Path) -> dict[str, list[tuple[float, float]]]:
    """(delivered_at, generated_at) of every delivery, per follower, in order."""
    by_follower: dict[str, list[tuple[float, float]]] = defaultdict(list)
    with path.open(newline="") as src:
        for row in csv.DictReader(src):
            by_follower[row["follower"]].append(
                (float(row["delivered_at"]), float(row["generated_at"]))
            )
    return dict(by_follower)


def sawtooth(deliveries: Sequence[tuple[float, float]], end: float
             ) -> tuple[list[float], list[float]]:
    """The AoI curve through the deliveries: it rises with time and drops at each one."""
    times: list[float] = []
    ages: list[float] = []
    freshest = None
    for delivered, generated in deliveries:
        if freshest is not None:
            times.append(delivered)
            ages.append(delivered - freshest)
        freshest = generated if freshest is None else max(freshest, generated)
        times.append(delivered)
        ages.append(delivered - freshest)
    if freshest is not None and times and end > times[-1]:
        times.append(end)
        ages.append(end - freshest)
    return times, ages


def plot_aoi(path: Path, deliveries: Mapping[str, Sequence[tuple[float, float]]],
             start: float, end: float, zoom: float = 0.25) -> None:
    """AoI over time per follower: the whole run, and ``zoom`` seconds in the middle."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (whole, close) = plt.subplots(2, 1, figsize=(11, 7), constrained_layout=True)
    lo = (end - start - zoom) / 2
    hi = lo + zoom
    top = 0.0
    for follower in sorted(deliveries):
        times, ages = sawtooth(deliveries[follower], end)
        rel = [t - start for t in times]
        ms = [a * 1e3 for a in ages]
        whole.plot(rel, ms, linewidth=0.6, label=follower)
        close.plot(rel, ms, linewidth=1.0, label=follower)
        top = max([top, *(m for t, m in zip(rel, ms, strict=True) if lo <= t <= hi)])
    whole.set_title("Age of Information per follower (leader clock)")
    close.set_xlim(lo, hi)
    if top > 0:
        close.set_ylim(0, top * 1.1)
    close.set_title(f"{zoom:g} s in the middle of the run: the sawtooth")
    for axes in (whole, close):
        axes.set_xlabel("time since the first delivery (s)")
        axes.set_ylabel("AoI (ms)")
        axes.grid(alpha=0.3)
    whole.legend(loc="upper right", ncol=min(len(deliveries), 7), fontsize=8)
    fig.savefig(path, dpi=110)
    plt.close(fig)
