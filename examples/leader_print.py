"""A leader that prints each fresh update it polls from its swarm's followers.

    python examples/leader_print.py
"""

from __future__ import annotations

from common import end_time, left, open_session, parser, run

from wiswarm_zenoh import FifoChannel, Leader


def main() -> None:
    args = parser("A leader printing deliveries.").parse_args()
    end = end_time(args)
    with open_session(args) as session, \
            Leader(session, args.swarm, FifoChannel(64),
                   on_join=lambda name: print(f"{name} joined", flush=True),
                   on_leave=lambda name: print(f"{name} left", flush=True)) as leader:
        print(f"leader of swarm {args.swarm!r} (Ctrl-C to stop)", flush=True)
        while (timeout := left(end)) != 0.0:
            delivery = leader.recv(timeout)
            if delivery is not None:
                print(f"{delivery.follower}: {len(delivery.payload)} bytes, "
                      f"{delivery.age * 1e3:.1f} ms old: {delivery.payload[:60]!r}", flush=True)


if __name__ == "__main__":
    run(main)
