"""What ``bench_soak.py`` makes of its samples at the end: the table, the targets with the
figures each was judged on, the plot (PNG), the samples (CSV) and the summary (JSON)."""

from __future__ import annotations

import csv
import dataclasses
import json
import statistics
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from soak_plan import Plan
from soak_swarm import Swarm

MIB = 2**20


@dataclass
class Sample:
    """One interval's figures of the router, the leader and the steady followers, and
    what happened in it: a row of the table."""

    t: float  # end of the interval, seconds from the start
    nodes: dict[str, dict[str, int]]  # "router", "leader", "follower (largest)"
    leader: str  # which leader process ("leader" or "leader2")
    events: list[str]


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
