"""A leader that steers its followers: each gets a waypoint ``(t, x, y, z)``, a point
on a circle one --period ahead (t on the leader's clock), moved on by a few degrees
every --period seconds (the followers print them: see follower_bytes.py).

    python examples/leader_waypoints.py
"""

from __future__ import annotations

import contextlib
import math
import time

from common import end_time, open_session, parser, run, wait_until

from wiswarm_zenoh import Leader


def main() -> None:
    flags = parser("A leader steering its followers around a circle.")
    flags.add_argument("--radius", type=float, default=20.0, help="metres (default 20)")
    flags.add_argument("--period", type=float, default=1.0,
                       help="seconds between new waypoints (default 1)")
    args = flags.parse_args()
    end = end_time(args)
    with open_session(args) as session, Leader(session, args.swarm) as leader:
        print(f"steering swarm {args.swarm!r} (Ctrl-C to stop)", flush=True)
        step, next_at = 0, time.monotonic()
        while next_at < end:
            followers = leader.followers
            for i, follower in enumerate(followers):
                angle = 2 * math.pi * i / len(followers) + math.radians(5 * step)
                x, y = args.radius * math.cos(angle), args.radius * math.sin(angle)
                with contextlib.suppress(ValueError):  # it left since: polled no more
                    leader.set_control(follower, [(time.time() + args.period, x, y, 10.0)])
            step, next_at = step + 1, next_at + args.period
            wait_until(min(next_at, end))


if __name__ == "__main__":
    run(main)
