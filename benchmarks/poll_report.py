"""What ``bench_poll.py`` prints of its rounds: (a) the bare get loop against (b) the
leader, paired round by round so that the machine's drift cancels, the time (b) adds to
each poll, each follower's AoI next to the round-robin floor; and (c), the leader watched,
against (b). Apart from the measuring so that each reads on its own."""

from __future__ import annotations

import argparse
import os
import statistics
from typing import Any


def report(n: int, args: argparse.Namespace, bare: list[float], leader: list[float],
           stats: list[dict[str, Any]], fast_share: float, early_share: float) -> None:
    """(a) and (b) of one N: medians, the paired ratio and added time with their
    quartiles (the noise), and the last (b) round's AoI per follower."""
    a, b = statistics.median(bare), statistics.median(leader)
    s = 1.0 / a
    floor = s * (n / 2 + 1)
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    source = f"camera at {args.camera:g} Hz" if args.camera else "a fresh update every poll"
    hosts = "one host process" if args.layout == "host" else "a process per follower"
    print(f"\nN = {n}, {args.frame_bytes} B updates ({source}), {args.mode} mode via a router, "
          f"followers in {hosts}, {args.rounds} rounds of {args.seconds:g} s, "
          f"control period {args.control_period:g} s "
          f"(load average {load} on {os.cpu_count()} CPUs)")
    print(f"  (a) bare get loop   {a:8.0f} polls/s   (rounds: "
          f"{', '.join(f'{x:.0f}' for x in bare)})   S = {s * 1e3:.3f} ms")
    print(f"  (b) leader loop     {b:8.0f} polls/s   (rounds: "
          f"{', '.join(f'{x:.0f}' for x in leader)})   "
          f"{fast_share:.0%} sent the moment the reply before came, "
          f"{early_share:.0%} before it was judged")
    paired = sorted(y / x for x, y in zip(bare, leader, strict=True))
    low, median, high = statistics.quantiles(paired, n=4) if len(paired) > 1 else paired * 3
    print(f"  ratio (b)/(a)       {median:8.2f}   target >= 0.80, goal 0.90   (median of the "
          f"{len(paired)} pairs of rounds, quartiles {low:.2f} .. {high:.2f}; ratio of the medians "
          f"{b / a:.2f})")
    # The time the middleware adds to each poll, next to what the target allows: it says
    # whether a low ratio comes from a larger overhead or from a faster bare loop.
    added = sorted((1.0 / y - 1.0 / x) * 1e6 for x, y in zip(bare, leader, strict=True))
    low, median, high = statistics.quantiles(added, n=4) if len(added) > 1 else added * 3
    print(f"  added per poll      {median:8.0f} us   (quartiles {low:.0f} .. {high:.0f}; "
          "the target allows 80 us)")
    print(f"  mean AoI per follower, last (b) round ({args.policy}); "
          f"round-robin floor S (N/2 + 1) = {floor * 1e3:.2f} ms")
    for record in sorted(stats, key=lambda r: str(r["follower"])):
        print(f"    {record['follower']:>6}  {float(record['mean_aoi_s']) * 1e3:7.2f} ms"
              f"   p95 {float(record['p95_aoi_s']) * 1e3:7.2f} ms   polls {record['polls']}")


def report_watched(leader: list[float], watched: list[tuple[float, float]]) -> None:
    """(c) against (b), paired round by round: what a delivery-stream reader costs."""
    paired = sorted(w / x for x, (w, _) in zip(leader, watched, strict=True))
    low, median, high = statistics.quantiles(paired, n=4) if len(paired) > 1 else paired * 3
    records = statistics.median(got for _, got in watched)
    print(f"  (c) leader watched  {statistics.median(w for w, _ in watched):8.0f} polls/s   "
          f"a subscriber to leader/deliveries got {records:.0f} records/s")
    print(f"  ratio (c)/(b)       {median:8.3f}   target >= 0.98   (median of the "
          f"{len(paired)} pairs of rounds, quartiles {low:.3f} .. {high:.3f})")
