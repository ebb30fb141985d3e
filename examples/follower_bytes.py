"""A follower that sends its own bytes: it offers a reading at --rate (any rate: the
leader gets the freshest when it polls) and prints the waypoints its leader sends.

    python examples/follower_bytes.py --id uav1
"""

from __future__ import annotations

import time

from common import end_time, open_session, parser, run

from wiswarm_zenoh import Follower, Waypoint


def on_control(waypoints: list[Waypoint]) -> None:
    print(f"waypoints: {[tuple(w) for w in waypoints]}", flush=True)


def main() -> None:
    flags = parser("A follower offering its own bytes.")
    flags.add_argument("--id", default="uav1", help="this follower's id (default uav1)")
    flags.add_argument("--rate", type=float, default=10.0, help="readings per second")
    args = flags.parse_args()
    end = end_time(args)
    with open_session(args) as session, \
            Follower(session, args.swarm, args.id, on_control=on_control) as follower:
        print(f"follower {args.id} in swarm {args.swarm!r} (Ctrl-C to stop)", flush=True)
        reading = 0
        try:
            while time.monotonic() < end:
                reading += 1
                follower.offer(f"{args.id} reading {reading} at {time.time():.3f}".encode())
                time.sleep(1 / args.rate)  # the sensor's pace, not a wait for anything
        finally:  # at Ctrl-C too
            print(f"{follower.polls} polls answered", flush=True)


if __name__ == "__main__":
    run(main)
