"""Soak: a swarm run as an operator runs one, for half an hour, with followers coming
and going, a hung follower and a leader restart; does anything grow, does anyone dip?

Every node is ``wiswarm router|leader|follower`` with the command line's defaults (50 kB
frames at 100 Hz, shared memory off unless ``--shared-memory``), each a client of the
router on loopback, each its own ``spawn`` process. Over ``--minutes``:

- ``--steady`` followers (8) run throughout;
- a new follower joins every 10 s and the one before it is killed, SIGKILL and SIGTERM
  in turn;
- one steady follower is stopped (SIGSTOP) for 3 s every minute;
- the leader is killed (SIGKILL) once, at 60 % of the run, and started again at once.

Every 30 s: resident memory (and the shared part), open fds and threads of the router
and the leader, the largest of the steady followers'; each steady follower's delivery
rate (from the leader's ``leader/deliveries`` stream, watched from this process) against
its rate over the first 5 minutes, and its largest gap between deliveries. At the end:
the table, the targets (router and leader memory at most +15 % from the 5-minute sample
to the end, fds and threads flat; every steady follower at least 80 % of its rate in
every interval but the leader kill's; nothing left in /dev/shm of what these processes
mapped), and a plot (PNG), the samples (CSV) and a summary (JSON) in ``--out``.

    .venv/bin/python benchmarks/bench_soak.py                 # 25 minutes
    .venv/bin/python benchmarks/bench_soak.py --minutes 3     # a quick look
    .venv/bin/python benchmarks/bench_soak.py --shared-memory # as before the decision
    .venv/bin/python benchmarks/bench_soak.py --minutes 0.4 --steady 2 --time-scale 0.2
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import heapq
import json
import math
import multiprocessing
import os
import signal
import socket
import statistics
import threading
import time
from dataclasses import dataclass, field
from multiprocessing.context import SpawnProcess
from pathlib import Path
from typing import Any

from bench_shm import zenoh_segments

from wiswarm_zenoh import DeliveryRecord, LeaderSummary, Observer
from wiswarm_zenoh.transport import SessionSpec
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

SWARM = "soak"
READY_TIMEOUT = 60.0  # seconds; a loaded 2-core machine starts ten interpreters slowly
MIB = 2**20


@dataclass(frozen=True)
class Plan:
    """When each fault comes, in seconds from the start (the steady followers' first
    deliveries); the defaults are the issue's."""

    minutes: float = 25.0
    steady: int = 8
    churn_every: float = 10.0
    hang_every: float = 60.0
    hang_at: float = 20.0  # into each hang period
    hang_for: float = 3.0
    leader_kill_at: float = 0.6  # of the run: mid-way through the interval there
    sample_every: float = 30.0
    baseline: float = 300.0  # the steady followers' reference rate: the first 5 minutes
    shared_memory: bool = False

    @property
    def seconds(self) -> float:
        return self.minutes * 60.0

    @property
    def kill_time(self) -> float:
        """When the leader is killed: in the middle of an interval, so that the interval
        it falls in is plain, and no sample catches the new leader starting."""
        every = self.sample_every
        return math.floor(self.seconds * self.leader_kill_at / every) * every + every / 2

    def scaled(self, factor: float) -> Plan:
        """Every period (churn, hang, samples, the reference window) times ``factor``:
        the same run, quicker (tests/test_soak.py)."""
        return dataclasses.replace(
            self, churn_every=self.churn_every * factor, hang_every=self.hang_every * factor,
            hang_at=self.hang_at * factor, hang_for=self.hang_for * factor,
            sample_every=self.sample_every * factor, baseline=self.baseline * factor)


def cli_node(argv: list[str], log_path: str) -> None:
    """A ``spawn`` child running ``wiswarm *argv``: its stdout (the leader's table) is
    dropped, its stderr (warnings, a traceback) kept in ``log_path``."""
    from wiswarm_zenoh.cli.main import main
    from wiswarm_zenoh.programs.process_exit import exit_without_finalizing

    with open(os.devnull, "w") as devnull, open(log_path, "a") as log:
        os.dup2(devnull.fileno(), 1)
        os.dup2(log.fileno(), 2)
    exit_without_finalizing(main(argv))


def proc_status(pid: int) -> dict[str, int]:
    """Resident memory and its shared-memory part (bytes), threads, open fds."""
    values = {}
    with open(f"/proc/{pid}/status") as status:
        for line in status:
            key, _, rest = line.partition(":")
            if key in ("VmRSS", "RssShmem"):
                values[key] = int(rest.split()[0]) * 1024
            elif key == "Threads":
                values[key] = int(rest)
    values["fds"] = len(os.listdir(f"/proc/{pid}/fd"))
    return values


@dataclass
class Deliveries:
    """Each steady follower's deliveries per interval from ``begin``, and the largest gap
    ending in it (the leader's clock, which is this host's ``time.time``)."""

    every: float
    followers: tuple[str, ...]
    start: float = math.inf
    counts: dict[str, dict[int, int]] = field(default_factory=dict)
    gaps: dict[str, dict[int, float]] = field(default_factory=dict)
    last: dict[str, float] = field(default_factory=dict)
    mark: float = math.inf
    first_after: dict[str, float] = field(default_factory=dict)
    leader_seen: threading.Event = field(default_factory=threading.Event)
    cond: threading.Condition = field(default_factory=threading.Condition)

    def __call__(self, observation: object) -> None:
        if isinstance(observation, LeaderSummary):
            self.leader_seen.set()
        if not isinstance(observation, DeliveryRecord) or observation.outcome != "delivered" \
                or observation.follower not in self.followers:
            return
        at, who = observation.delivered_at, observation.follower
        with self.cond:
            if at >= self.start:
                k = math.floor((at - self.start) / self.every)
                counts = self.counts.setdefault(who, {})
                counts[k] = counts.get(k, 0) + 1
                if who in self.last:
                    gaps = self.gaps.setdefault(who, {})
                    gaps[k] = max(gaps.get(k, 0.0), at - self.last[who])
            self.last[who] = max(self.last.get(who, at), at)
            if at >= self.mark and who not in self.first_after:
                self.first_after[who] = at
                self.cond.notify_all()

    def begin(self) -> float:
        """Count from now on; the time."""
        with self.cond:
            self.start = time.time()
            return self.start

    def mark_now(self) -> float:
        """From now on, note each follower's first delivery (``first_after``)."""
        with self.cond:
            self.mark = time.time()
            self.first_after = {}
            return self.mark

    def wait_for_all(self, timeout: float) -> None:
        """Until every follower has delivered since ``mark_now``."""
        with self.cond:
            if not self.cond.wait_for(
                    lambda: len(self.first_after) == len(self.followers), timeout):
                raise RuntimeError(f"only {sorted(self.first_after)} delivered")


class Swarm:
    """The run's processes by name, each a ``wiswarm`` command in a ``spawn`` child."""

    def __init__(self, port: int, out: Path, shared_memory: bool) -> None:
        self._ctx = multiprocessing.get_context("spawn")
        self.endpoint = f"tcp/127.0.0.1:{port}"
        self._out = out
        self._flags = ["--no-multicast-scouting", *(["--shared-memory"] if shared_memory
                                                    else [])]
        self.procs: dict[str, SpawnProcess] = {}
        self.ended: dict[str, int | None] = {}  # name: exit code
        self.expected: dict[str, int] = {}  # name: the exit code its stop should give
        self.segments: set[str] = set()  # every Zenoh segment file one of them mapped

    def start(self, name: str, command: list[str]) -> None:
        argv = [*command, *self._flags]
        if command[0] == "router":
            argv += ["-l", self.endpoint]
        else:
            argv += ["--swarm", SWARM, "-m", "client", "-e", self.endpoint]
        proc = self._ctx.Process(target=cli_node, name=name,
                                 args=(argv, str(self._out / f"{name}.log")))
        proc.start()
        self.procs[name] = proc

    def pid(self, name: str) -> int:
        pid = self.procs[name].pid
        assert pid is not None
        return pid

    def note_segments(self) -> None:
        for proc in self.procs.values():
            if proc.pid is not None and proc.is_alive():
                self.segments |= zenoh_segments(proc.pid)

    def end(self, name: str, how: signal.Signals) -> None:
        """Stop ``name`` by ``how`` (SIGTERM: cleanly, exit 0; SIGKILL: -9); reaped later.
        One that has ended already (multiprocessing reaps ended children whenever it
        starts one) is left as it is: its pid may be another process's by now."""
        self.segments |= zenoh_segments(self.pid(name))
        self.expected.setdefault(name, 0 if how == signal.SIGTERM else -how)
        if self.procs[name].is_alive():
            os.kill(self.pid(name), how)

    def reap(self, wait: float = 0.0) -> None:
        """Join what has ended (waiting up to ``wait`` s for each one told to end)."""
        for name in list(self.procs):
            proc = self.procs[name]
            proc.join(wait if name in self.expected else 0.0)
            if not proc.is_alive():
                self.ended[name] = proc.exitcode
                del self.procs[name]

    def stop_all(self) -> None:
        self.note_segments()
        for name in list(self.procs):
            self.end(name, signal.SIGTERM)
        self.reap(15.0)
        for name, proc in list(self.procs.items()):
            proc.kill()
            proc.join(5.0)
            self.ended[name] = proc.exitcode

    def _stopped_starting(self, name: str, code: int | None) -> bool:
        """Told SIGTERM while still starting (the spawn child importing, before the
        command installed its handler), a process ends by the signal itself: as told,
        not a crash. A running node's clean stop is tests/transport/test_cli.py's."""
        return self.expected.get(name) == 0 and code == -signal.SIGTERM

    def surprises(self) -> list[str]:
        """Processes that ended other than told (a crash), and tracebacks in the logs."""
        found = [f"{name} ended with {code}" for name, code in self.ended.items()
                 if code != self.expected.get(name) and not self._stopped_starting(name, code)]
        found += [f"{log.name} has a traceback" for log in sorted(self._out.glob("*.log"))
                  if "Traceback" in log.read_text(errors="replace")]
        return found


def wait_for_port(port: int, timeout: float) -> None:
    """Until the router accepts connections."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
            return
        except OSError:
            if time.monotonic() > deadline:
                raise RuntimeError("the router did not listen") from None
            time.sleep(0.05)


@dataclass
class Sample:
    t: float  # end of the interval, seconds from the start
    nodes: dict[str, dict[str, int]]  # "router", "leader", "follower (largest)"
    leader: str  # which leader process ("leader" or "leader2")
    events: list[str]


def sample(swarm: Swarm, leader: str, steady: list[str]) -> dict[str, dict[str, int]]:
    """The router's and the leader's figures, and the largest of each over the steady
    followers."""
    nodes = {"router": proc_status(swarm.pid("router")), "leader": proc_status(swarm.pid(leader))}
    followers = [proc_status(swarm.pid(name)) for name in steady]
    nodes["follower"] = {key: max(f[key] for f in followers) for key in followers[0]}
    return nodes


def run(plan: Plan, out: Path) -> dict[str, Any]:
    """The soak; its summary (also written to ``out``)."""
    out.mkdir(parents=True, exist_ok=True)
    port = free_tcp_port()
    swarm = Swarm(port, out, plan.shared_memory)
    steady = [f"steady{i}" for i in range(plan.steady)]
    hung = steady[-1]
    observer_spec = SessionSpec(mode="client", connect=(swarm.endpoint,),
                                multicast_scouting=False)
    samples: list[Sample] = []
    resumed: dict[str, float] = {}
    try:
        swarm.start("router", ["router"])
        wait_for_port(port, READY_TIMEOUT)
        deliveries = Deliveries(plan.sample_every, tuple(steady))
        with observer_spec.open() as session, Observer(session, SWARM, deliveries):
            swarm.start("leader", ["leader"])
            for name in steady:
                swarm.start(name, ["follower", "--id", name])
            if not deliveries.leader_seen.wait(READY_TIMEOUT):
                raise RuntimeError("the leader did not come up")
            deliveries.mark_now()
            deliveries.wait_for_all(READY_TIMEOUT)
            start = deliveries.begin()
            samples, resumed = _soak(plan, swarm, deliveries, steady, hung, start)
    finally:
        swarm.stop_all()
    counts, gaps = deliveries.counts, deliveries.gaps
    summary = report(plan, samples, counts, gaps, steady, resumed, swarm, out)
    return summary


def _schedule(plan: Plan) -> list[tuple[float, int, str]]:
    """(time, order, what) of every event of the run."""
    events: list[tuple[float, int, str]] = []
    n = int(plan.seconds // plan.churn_every)
    events += [(k * plan.churn_every, 2, f"churn {k}") for k in range(1, n + 1)
               if k * plan.churn_every < plan.seconds]
    m = int(plan.seconds // plan.hang_every) + 1
    for k in range(m):
        at = k * plan.hang_every + plan.hang_at
        if at + plan.hang_for < plan.seconds:
            events += [(at, 1, "hang"), (at + plan.hang_for, 1, "resume")]
    events.append((plan.kill_time, 0, "leader kill"))
    k = 1
    while k * plan.sample_every <= plan.seconds + 1e-9:
        # Half a second late: the leader's last batch of the interval has come in.
        events.append((k * plan.sample_every + 0.5, 3, "sample"))
        k += 1
    heapq.heapify(events)
    return events


def _soak(plan: Plan, swarm: Swarm, deliveries: Deliveries, steady: list[str], hung: str,
          start: float) -> tuple[list[Sample], dict[str, float]]:
    events = _schedule(plan)
    leader, churned, kills = "leader", None, 0
    samples: list[Sample] = []
    happened: list[tuple[float, str]] = []  # since the last sample
    resumed: dict[str, float] = {}
    killed_at = math.nan
    while events:
        at, _, what = heapq.heappop(events)
        time.sleep(max(0.0, start + at - time.time()))
        if what.startswith("churn"):
            name = f"churn{what.split()[1]}"
            swarm.start(name, ["follower", "--id", name])
            if churned is not None:
                swarm.end(churned, signal.SIGKILL if kills % 2 == 0 else signal.SIGTERM)
                kills += 1
            churned = name
            swarm.reap()
        elif what == "hang":
            os.kill(swarm.pid(hung), signal.SIGSTOP)
            happened.append((at, "hang"))
        elif what == "resume":
            os.kill(swarm.pid(hung), signal.SIGCONT)
        elif what == "leader kill":
            killed_at = deliveries.mark_now()
            swarm.end(leader, signal.SIGKILL)
            leader = "leader2"
            swarm.start(leader, ["leader"])
            happened.append((at, "leader kill"))
        else:
            with deliveries.cond:  # every steady follower delivered again: how soon
                if not math.isnan(killed_at) and not resumed \
                        and len(deliveries.first_after) == len(steady):
                    resumed = {who: t - killed_at for who, t in deliveries.first_after.items()}
            swarm.note_segments()
            t = at - 0.5
            here = [what for when, what in happened if when < t]  # this interval's
            happened = [(when, what) for when, what in happened if when >= t]
            samples.append(Sample(t, sample(swarm, leader, steady), leader, here))
            print_row(samples[-1], deliveries, steady, round(t / plan.sample_every) - 1)
    return samples, resumed


def print_row(s: Sample, deliveries: Deliveries, steady: list[str], k: int) -> None:
    with deliveries.cond:
        rates = [deliveries.counts.get(who, {}).get(k, 0) for who in steady]
        gap = max(deliveries.gaps.get(who, {}).get(k, 0.0) for who in steady)
    r, ld = s.nodes["router"], s.nodes["leader"]
    print(f"{s.t / 60:5.1f} min  router {r['VmRSS'] / MIB:6.0f} MiB {r['fds']:4d} fds "
          f"{r['Threads']:3d} thr   {s.leader:7} {ld['VmRSS'] / MIB:6.0f} MiB {ld['fds']:4d} fds "
          f"{ld['Threads']:3d} thr   deliveries {min(rates)}..{max(rates)}  largest gap "
          f"{gap:5.2f} s  {', '.join(s.events)}", flush=True)


def report(plan: Plan, samples: list[Sample], counts: dict[str, dict[int, int]],
           gaps: dict[str, dict[int, float]], steady: list[str], resumed: dict[str, float],
           swarm: Swarm, out: Path) -> dict[str, Any]:
    """The table, the targets, the plot, the files; the summary."""
    every = plan.sample_every
    base_n = max(1, int(min(plan.baseline, plan.seconds / 3) // every))
    base = {who: statistics.mean(counts.get(who, {}).get(k, 0) for k in range(base_n)) / every
            for who in steady}
    rows = []
    for k, s in enumerate(samples):
        ratios = {who: counts.get(who, {}).get(k, 0) / every / base[who] if base[who] else 0.0
                  for who in steady}
        rows.append({
            "t_min": round(s.t / 60, 2), "leader": s.leader, "events": " ".join(s.events),
            **{f"{node}_{key}": value for node, figures in s.nodes.items()
               for key, value in figures.items()},
            "min_rate_ratio": round(min(ratios.values()), 3),
            "min_rate_follower": min(ratios, key=lambda who: ratios[who]),
            # The followers never stopped: do they dip with the stopped one (together)?
            "others_min_rate_ratio": round(min(r for who, r in ratios.items()
                                               if who != steady[-1]), 3),
            "largest_gap_s": round(max(gaps.get(who, {}).get(k, 0.0) for who in steady), 3),
        })
    with open(out / "samples.csv", "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    time.sleep(1.0)  # the sweepers of shared-memory runs see their processes end first
    left = sorted(path for path in swarm.segments if Path(path).exists())
    summary = targets(plan, samples, rows, base, resumed, swarm, left)
    (out / "summary.json").write_text(json.dumps({"plan": dataclasses.asdict(plan),
                                                  **summary, "rows": rows}, indent=1))
    print_table(rows, summary)
    plot(rows, plan, out / "soak.png")
    print(f"\nplot, samples and summary in {out}/")
    return summary


def targets(plan: Plan, samples: list[Sample], rows: list[dict[str, Any]],
            base: dict[str, float], resumed: dict[str, float], swarm: Swarm,
            left: list[str]) -> dict[str, Any]:
    """Each target, with the figures it was judged on."""
    at5 = min(range(len(samples)),
              key=lambda k: abs(samples[k].t - min(plan.baseline, plan.seconds / 3)))
    last = samples[-1]
    growth: dict[str, Any] = {}
    for node in ("router", "leader", "follower"):  # a restarted leader: from its first
        same = [s for s in samples[at5:] if node != "leader" or  # whole interval on
                (s.leader == last.leader and "leader kill" not in s.events)]
        a = same[0].nodes[node]
        b = last.nodes[node]
        growth[node] = {"from_min": round(same[0].t / 60, 1),
                        "rss_mib": [round(a["VmRSS"] / MIB), round(b["VmRSS"] / MIB)],
                        "rss_growth": round(b["VmRSS"] / a["VmRSS"] - 1, 3),
                        "shmem_mib": [round(a["RssShmem"] / MIB), round(b["RssShmem"] / MIB)],
                        "fds": [a["fds"], b["fds"]], "threads": [a["Threads"], b["Threads"]]}
    kill_rows = [k for k, r in enumerate(rows) if "leader kill" in r["events"]]
    judged = [r for k, r in enumerate(rows) if k not in kill_rows]
    worst = min(judged, key=lambda r: r["min_rate_ratio"]) if judged else None
    return {
        "from_the_5_minute_sample": {"router": growth["router"], "leader": growth["leader"],
                                     "largest_steady_follower": growth["follower"],
                                     "first_leader_before_its_kill": _first_leader(samples, at5)},
        "memory_target_met": all(growth[n]["rss_growth"] <= 0.15 for n in ("router", "leader")),
        "fds_and_threads_flat": all(growth[n]["fds"][1] <= growth[n]["fds"][0] + 2 and
                                    growth[n]["threads"][1] <= growth[n]["threads"][0] + 2
                                    for n in ("router", "leader")),
        "baseline_rates": {who: round(rate, 1) for who, rate in base.items()},
        "lowest_rate_ratio": None if worst is None else worst["min_rate_ratio"],
        "lowest_rate_at_min": None if worst is None else worst["t_min"],
        "lowest_rate_ratio_never_stopped": min((r["others_min_rate_ratio"] for r in judged),
                                               default=None),
        "intervals_below_80": [(r["t_min"], r["min_rate_ratio"], r["events"]) for r in judged
                               if r["min_rate_ratio"] < 0.8],
        "resumed_after_leader_kill_s": round(max(resumed.values()), 2) if resumed else None,
        "segments_mapped": len(swarm.segments),
        "segments_left": left,
        "surprises": swarm.surprises(),
    }


def _first_leader(samples: list[Sample], at5: int) -> list[int] | None:
    """The first leader's memory (MiB) at the 5-minute sample and at its last sample."""
    mine = [s for s in samples[at5:] if s.leader == "leader"]
    if not mine:
        return None
    return [round(mine[0].nodes["leader"]["VmRSS"] / MIB),
            round(mine[-1].nodes["leader"]["VmRSS"] / MIB)]


def print_table(rows: list[dict[str, Any]], summary: dict[str, Any]) -> None:
    print(f"\n{'min':>5} {'router MiB':>10} {'fds':>4} {'thr':>4} {'leader MiB':>10} {'fds':>4} "
          f"{'thr':>4} {'follower MiB':>12} {'fds':>4} {'rate >=':>8} {'others':>7} "
          f"{'gap s':>6}  events")
    for r in rows:
        print(f"{r['t_min']:5.1f} {r['router_VmRSS'] / MIB:10.0f} {r['router_fds']:4d} "
              f"{r['router_Threads']:4d} {r['leader_VmRSS'] / MIB:10.0f} {r['leader_fds']:4d} "
              f"{r['leader_Threads']:4d} {r['follower_VmRSS'] / MIB:12.0f} "
              f"{r['follower_fds']:4d} {r['min_rate_ratio']:8.2f} "
              f"{r['others_min_rate_ratio']:7.2f} {r['largest_gap_s']:6.2f}  "
              f"{r['events']}{' (' + r['leader'] + ')' if r['leader'] != 'leader' else ''}")
    print()
    for key, value in summary.items():
        print(f"{key}: {value}")


def plot(rows: list[dict[str, Any]], plan: Plan, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = [r["t_min"] for r in rows]
    fig, (mem, fds, rate) = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    for node in ("router", "leader", "follower"):
        mem.plot(t, [r[f"{node}_VmRSS"] / MIB for r in rows], marker=".",
                 label=f"{node}{' (largest steady)' if node == 'follower' else ''}")
        fds.plot(t, [r[f"{node}_fds"] for r in rows], marker=".", label=f"{node} fds")
    fds.plot(t, [r["router_Threads"] for r in rows], ls="--", label="router threads")
    fds.plot(t, [r["leader_Threads"] for r in rows], ls="--", label="leader threads")
    rate.plot(t, [r["min_rate_ratio"] for r in rows], marker=".",
              label="lowest steady follower's rate / its first minutes'")
    rate.plot(t, [r["others_min_rate_ratio"] for r in rows], marker=".",
              label="lowest of those never stopped")
    rate.axhline(0.8, color="grey", ls=":", label="target 0.8")
    for ax in (mem, fds, rate):
        ax.axvline(plan.kill_time / 60, color="red", ls=":", lw=1)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    mem.set_ylim(bottom=0)
    fds.set_ylim(bottom=0)
    rate.set_ylim(bottom=0)
    mem.set_ylabel("resident MiB")
    fds.set_ylabel("open fds, threads")
    rate.set_ylabel("rate ratio")
    rate.set_xlabel("minutes (red: the leader killed and restarted)")
    shm = "on" if plan.shared_memory else "off"
    mem.set_title(f"soak: {plan.steady} steady followers, churn every {plan.churn_every:g} s, "
                  f"a hang every {plan.hang_every:g} s; shared memory {shm}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=Plan.minutes)
    parser.add_argument("--steady", type=int, default=Plan.steady)
    parser.add_argument("--shared-memory", action="store_true",
                        help="every node with Zenoh's shared memory on (as before the decision)")
    parser.add_argument("--time-scale", type=float, default=1.0, metavar="FACTOR",
                        help="every period (churn, hang, samples) times FACTOR")
    parser.add_argument("--out", type=Path,
                        default=Path("runs") / time.strftime("soak-%Y%m%d-%H%M%S"))
    args = parser.parse_args()
    plan = Plan(minutes=args.minutes, steady=args.steady, shared_memory=args.shared_memory)
    run(plan.scaled(args.time_scale), args.out)


if __name__ == "__main__":
    main()
