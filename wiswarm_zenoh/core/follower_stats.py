"""One follower's figures as the leader publishes them (DESIGN.md section 3)."""

from __future__ import annotations

from dataclasses import dataclass, fields

from wiswarm_zenoh.core.members import robot_of


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

    @property
    def robot(self) -> str:
        """The robot this member is a stream of (itself, for a robot of one stream)."""
        return robot_of(self.follower)

    def as_dict(self) -> dict[str, float | int | str]:
        """The record as a plain dict, the stats JSON's fields (and ``robot``)."""
        # Its fields are plain numbers and a string: read by name is the whole of it, far
        # cheaper than ``asdict``'s deep copy (made for each follower in each stats put);
        # not ``vars``: the compiled core's classes have no ``__dict__``.
        record: dict[str, float | int | str] = {name: getattr(self, name) for name in _FIELDS}
        record["robot"] = robot_of(self.follower)
        return record


_FIELDS = tuple(field.name for field in fields(FollowerStats))
