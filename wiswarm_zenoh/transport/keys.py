"""The key expressions of DESIGN.md section 3, built in one place from checked names."""

from __future__ import annotations

from dataclasses import dataclass

from wiswarm_zenoh.core.members import SITE_SEPARATOR, STREAM_SEPARATOR, site_of

ROOT = "wiswarm"
RESERVED = frozenset({"leader", "leaders", "control", "members"})
_FORBIDDEN = frozenset("/*$?#")


def check_name(name: str, what: str) -> str:
    """Return ``name`` if it is a single key chunk; raise ValueError naming ``what``."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"{what} must be a non-empty string")
    bad = sorted(_FORBIDDEN.intersection(name))
    if bad:
        raise ValueError(f"{what} {name!r} must not contain {' '.join(bad)}")
    if name != name.strip() or any(c.isspace() for c in name):
        raise ValueError(f"{what} {name!r} must not contain spaces")
    return name


def check_follower(name: str) -> str:
    """A follower id: a key chunk that is not one of the swarm's own words."""
    check_name(name, "follower id")
    if name in RESERVED:
        raise ValueError(f"follower id {name!r} is reserved: "
                         f"{', '.join(sorted(RESERVED))} are not follower names")
    return name


def check_robot(name: str) -> str:
    """A robot's id (``wiswarm follower --id``): a follower id without ``~``, which joins
    a robot and its stream in a member's name, nor ``.``, which joins a site and its
    follower in a cloud's."""
    check_follower(name)
    for separator, joins in ((STREAM_SEPARATOR, f"a robot and its streams in a member's "
                              f"name (<id>{STREAM_SEPARATOR}<stream>)"),
                             (SITE_SEPARATOR, f"a site and its follower in a cloud's "
                              f"(<site>{SITE_SEPARATOR}<id>)")):
        if separator in name:
            raise ValueError(f"follower id {name!r} must not contain {separator}: it joins "
                             f"{joins}")
    return name


def stream_member(robot: str, stream: str) -> str:
    """The member that serves ``robot``'s stream ``stream``: ``<robot>~<stream>``."""
    check_name(stream, "stream name")
    return check_follower(f"{check_robot(robot)}{STREAM_SEPARATOR}{stream}")


@dataclass(frozen=True)
class SwarmKeys:
    """Every key of one swarm: ``wiswarm/<swarm>/...``."""

    swarm: str

    def __post_init__(self) -> None:
        check_name(self.swarm, "swarm name")

    @property
    def prefix(self) -> str:
        """``wiswarm/<swarm>``."""
        return f"{ROOT}/{self.swarm}"

    @property
    def everything(self) -> str:
        """``wiswarm/<swarm>/**``: every key of the swarm."""
        return f"{self.prefix}/**"

    @property
    def control(self) -> str:
        """``wiswarm/<swarm>/control``: the leader's control information (msgpack) for
        its followers of no site (every follower of a single swarm)."""
        return f"{self.prefix}/control"

    def site_control(self, site: str | None) -> str:
        """``wiswarm/<swarm>/control/<site>``: a cloud's control for that site's
        followers only (``control`` for site None)."""
        return self.control if site is None else \
            f"{self.control}/{check_name(site, 'site name')}"

    def control_of(self, member: str) -> str:
        """Where the control for ``member`` goes: its site's key, or ``control``."""
        return self.site_control(site_of(member))

    @property
    def all_site_controls(self) -> str:
        """``wiswarm/<swarm>/control/*``: every site's control."""
        return f"{self.control}/*"

    @property
    def members(self) -> str:
        """``wiswarm/<swarm>/members/*``: every follower's liveliness token."""
        return f"{self.prefix}/members/*"

    @property
    def leaders(self) -> str:
        """Every leader's liveliness token (see ``election``)."""
        return f"{self.prefix}/leaders/**"

    def leader(self, name: str, started_us: int) -> str:
        """``wiswarm/<swarm>/leaders/<name>/<start us>``: one leader's liveliness token."""
        return f"{self.prefix}/leaders/{check_name(name, 'leader name')}/{started_us}"

    @property
    def leader_stats(self) -> str:
        """``wiswarm/<swarm>/leader/stats``: the active leader's JSON stats."""
        return f"{self.prefix}/leader/stats"

    @property
    def leader_deliveries(self) -> str:
        """``wiswarm/<swarm>/leader/deliveries``: every delivery and unanswered poll (JSON)."""
        return f"{self.prefix}/leader/deliveries"

    @property
    def all_stats(self) -> str:
        """``wiswarm/<swarm>/*/stats``: every follower's stats (and the leader's)."""
        return f"{self.prefix}/*/stats"

    @property
    def all_fresh(self) -> str:
        """``wiswarm/<swarm>/*/fresh``: every delivered update, of every follower."""
        return f"{self.prefix}/*/fresh"

    def member(self, follower: str) -> str:
        """``wiswarm/<swarm>/members/<follower>``: that follower's liveliness token."""
        return f"{self.prefix}/members/{check_follower(follower)}"

    def update(self, follower: str) -> str:
        """``wiswarm/<swarm>/<follower>/update``: its queryable; a ``get`` here is a poll."""
        return f"{self.prefix}/{check_follower(follower)}/update"

    def stats(self, follower: str) -> str:
        """``wiswarm/<swarm>/<follower>/stats``: its JSON stats, put by the leader."""
        return f"{self.prefix}/{check_follower(follower)}/stats"

    def fresh(self, follower: str) -> str:
        """``wiswarm/<swarm>/<follower>/fresh``: its delivered updates, put by the leader."""
        return f"{self.prefix}/{check_follower(follower)}/fresh"

    def weight(self, follower: str) -> str:
        """``wiswarm/<swarm>/<follower>/weight``: its application weight, set by the
        leader's side (the weight as decimal text)."""
        return f"{self.prefix}/{check_follower(follower)}/weight"

    @property
    def all_weights(self) -> str:
        """``wiswarm/<swarm>/*/weight``: every follower's weight setting."""
        return f"{self.prefix}/*/weight"

    def source(self, follower: str) -> str:
        """``wiswarm/<swarm>/<follower>/source``: under it, the liveliness token that says
        what the follower serves (a ROS 2 topic: ``.../source/ros2/<topic>/<type>/<hash>``),
        so a leader republishes it as what it is."""
        return f"{self.prefix}/{check_follower(follower)}/source"

    @property
    def all_sources(self) -> str:
        """``wiswarm/<swarm>/*/source/**``: every follower's source token."""
        return f"{self.prefix}/*/source/**"

    def follower_of(self, key: str, leaf: str) -> str | None:
        """The follower id in ``wiswarm/<swarm>/<id>/<leaf>`` (or ``members/<id>`` when
        ``leaf`` is "members"); None if ``key`` is anything else."""
        parts = key.split("/")
        if len(parts) != 4 or parts[0] != ROOT or parts[1] != self.swarm:
            return None
        name = parts[3] if leaf == "members" and parts[2] == "members" else None
        if leaf != "members" and parts[3] == leaf:
            name = parts[2]
        if name is None:
            return None
        try:
            return check_follower(name)
        except ValueError:
            return None
