"""An observer: prints a swarm's stats as its leader publishes them, without taking
part (nothing it does slows the leader).

    python examples/observer.py
"""

from __future__ import annotations

from common import end_time, left, open_session, parser, run

from wiswarm_zenoh import DeliveryRecord, FifoChannel, FollowerStats, LeaderSummary, Observer


def main() -> None:
    flags = parser("Print a swarm's stats.")
    flags.add_argument("--deliveries", action="store_true", help="print each delivery too")
    args = flags.parse_args()
    end = end_time(args)
    with open_session(args) as session, \
            Observer(session, args.swarm, FifoChannel(1024)) as observer:
        print(f"watching swarm {args.swarm!r} (Ctrl-C to stop)", flush=True)
        while (timeout := left(end)) != 0.0:
            match observer.recv(timeout):
                case LeaderSummary() as leader:
                    print(f"leader {leader.leader}: {len(leader.followers)} followers, "
                          f"{leader.polls_per_s:.0f} polls/s, mean AoI "
                          f"{leader.mean_aoi_s * 1e3:.1f} ms", flush=True)
                case FollowerStats() as stats:
                    print(f"  {stats.follower}: AoI {stats.aoi_s * 1e3:.1f} ms, "
                          f"{stats.deliveries} deliveries of {stats.polls} polls", flush=True)
                case DeliveryRecord() as record if args.deliveries:
                    print(f"  {record.follower}: {record.outcome}", flush=True)


if __name__ == "__main__":
    run(main)
