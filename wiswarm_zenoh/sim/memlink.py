"""A leader and its followers stepping over an in-memory lossy link, in virtual time.

The smallest shell around the core: no network, no clock. Tests use it to check the
protocol end to end, and ``python -m wiswarm_zenoh.sim.memlink`` shows AoI per follower.
"""

from __future__ import annotations

import argparse
import random
from collections.abc import Mapping
from dataclasses import dataclass, field

from wiswarm_zenoh.core import (
    Delivered,
    Event,
    Follower,
    FollowerConfig,
    Leader,
    LeaderConfig,
    PollRequest,
    drain,
)


@dataclass
class MemoryLink:
    """Carries polls and replies with a fixed latency; each reply is lost w.p. ``loss``.

    Followers produce an update every ``sample_interval`` seconds (their sensors);
    ``loss`` maps follower id to its loss probability (absent: 0).
    """

    leader: Leader
    followers: Mapping[str, Follower]
    rng: random.Random
    loss: Mapping[str, float] = field(default_factory=dict)
    latency: float = 0.002
    sample_interval: float = 0.01
    payload_bytes: int = 1000
    now: float = 0.0
    _next_sample: float = 0.0
    _request: PollRequest | None = None  # sent the moment the poll before it ended

    def __post_init__(self) -> None:
        for fid in self.followers:
            self.leader.add_follower(fid, self.now)

    def _sample_until(self, t: float) -> None:
        while self._next_sample <= t:
            for follower in self.followers.values():
                follower.offer(bytes(self.payload_bytes), self._next_sample)
            self._next_sample += self.sample_interval

    def step(self) -> list[Event]:
        """One poll: answered or lost; the next poll goes out as it ends, as a shell
        does, and then the leader's events are taken."""
        self._sample_until(self.now)
        while (request := self._request or self.leader.next_poll(self.now)) is None:
            wake = self.leader.get_timer()  # no source due yet: wait for the first
            if wake is None:
                raise RuntimeError("no follower to poll")
            self.now = wake
            self._sample_until(self.now)
        arrival = self.now + self.latency
        if self.rng.random() < self.loss.get(request.follower, 0.0):
            self.now = request.deadline
            self.leader.handle_timer(self.now)
        else:
            self._sample_until(arrival)
            reply = self.followers[request.follower].on_poll(request.payload, arrival, arrival)
            self.now = arrival + self.latency
            self.leader.receive_reply(request.follower, reply, self.now)
        self._request = self.leader.next_poll(self.now)
        return drain(self.leader)

    def run(self, duration: float) -> list[Event]:
        events: list[Event] = []
        end = self.now + duration
        while self.now < end:
            events.extend(self.step())
        return events


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--followers", type=int, default=5)
    parser.add_argument("--duration", type=float, default=60.0, help="virtual seconds")
    parser.add_argument("--policy", default="whittle")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rng = random.Random(args.seed)
    followers = {f"uav{i}": Follower(f"uav{i}", FollowerConfig()) for i in range(args.followers)}
    link = MemoryLink(
        Leader(LeaderConfig(policy=args.policy), rng), followers, rng,
        loss={fid: 0.1 * i for i, fid in enumerate(followers)},
    )
    delivered = sum(isinstance(e, Delivered) for e in link.run(args.duration))
    print(f"{delivered} updates delivered in {args.duration:.0f} virtual s ({args.policy})")
    print(f"{'follower':>9} {'loss':>5} {'p_hat':>6} {'mean AoI ms':>12} {'p95 AoI ms':>11}")
    for i, fid in enumerate(followers):
        s = link.leader.stats(fid, link.now)
        print(f"{fid:>9} {0.1 * i:5.1f} {s.p_hat:6.2f} {1e3 * s.mean_aoi_s:12.2f}"
              f" {1e3 * s.p95_aoi_s:11.2f}")


if __name__ == "__main__":
    main()
