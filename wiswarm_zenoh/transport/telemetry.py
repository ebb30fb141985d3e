"""The stats JSON of DESIGN.md section 3, as published on the ``.../stats`` keys."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass

from wiswarm_zenoh.core import Delivered


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
    def of(cls, present: Mapping[str, float], polls_per_s: float, policy: str,
           uptime_s: float, leader: str = "", epoch: int = 0,
           in_flight: int = 1) -> LeaderSummary:
        """The summary of the followers ``present`` (each with its mean AoI; those that
        left are in their own stats)."""
        means = list(present.values())
        return cls(
            followers=list(present), polls_per_s=polls_per_s,
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
