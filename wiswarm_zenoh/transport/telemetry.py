"""The stats JSON of DESIGN.md section 3, as published on the ``.../stats`` keys."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from dataclasses import dataclass

from wiswarm_zenoh.core import Delivered, FollowerStats


def follower_stats(stats: FollowerStats, transport_errors: int) -> FollowerStats:
    """One follower's stats; ``errors`` adds the replies the transport already refused
    (error replies, oversized payloads) to those the core rejected."""
    return dataclasses.replace(stats, errors=stats.errors + transport_errors)


@dataclass(frozen=True)
class LeaderSummary:
    """``wiswarm/<swarm>/leader/stats``: the swarm at a glance."""

    followers: list[str]
    polls_per_s: float
    mean_aoi_s: float
    policy: str
    uptime_s: float
    leader: str = ""  # the active leader's name (see ``election``)
    epoch: int = 0  # its epoch: it grows at every takeover
    in_flight: int = 1  # polls it keeps out now (with --in-flight auto: as it found)

    @classmethod
    def of(cls, records: Sequence[FollowerStats], polls_per_s: float, policy: str,
           uptime_s: float, leader: str = "", epoch: int = 0,
           in_flight: int = 1) -> LeaderSummary:
        """The summary of one round of ``records``: the followers present, their mean AoI."""
        present = [r for r in records if r.present]  # those that left: in their own stats
        means = [r.mean_aoi_s for r in present]
        return cls(
            followers=[r.follower for r in present], polls_per_s=polls_per_s,
            mean_aoi_s=sum(means) / len(means) if means else 0.0, policy=policy,
            uptime_s=uptime_s, leader=leader, epoch=epoch, in_flight=in_flight,
        )

    def as_dict(self) -> dict[str, object]:
        """The JSON object published on ``leader/stats``."""
        return {"followers": self.followers, "polls_per_s": self.polls_per_s,
                "mean_aoi_s": self.mean_aoi_s, "policy": self.policy, "uptime_s": self.uptime_s,
                "leader": self.leader, "epoch": self.epoch, "in_flight": self.in_flight}


def to_json(record: dict[str, object] | dict[str, float | int | str]) -> bytes:
    return json.dumps(record, separators=(",", ":")).encode()


def fresh_attachment(event: Delivered) -> bytes:
    """Sent with a ``fresh`` re-publication: when the update was made and delivered
    (leader clock), so a subscriber can draw the update's age without the follower."""
    return to_json({"follower": event.follower, "update_seq": event.update_seq,
                    "generated_at": event.generated_at,
                    "delivered_at": event.delivered_at})
