"""A mission: phases in which robots join and leave, a robot's link degrades and the
application's weights move, read from a TOML file (``configs/missions/*.toml``).

A phase lasts ``seconds`` and names the robots that fly in it: a count (``robots = 4``
is drone1 .. drone4) or a list of names. ``link`` (a robot's share of its full link
rate, 1 the full rate) and ``weight`` (its application weight, 1 by default) change
from the phase that sets them on and hold until a later phase sets them again: a
mission file says what changes, as a mission does. Nothing here does I/O beyond reading
the file; errors are ``ValueError`` naming the phase and the field, one line each.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROBOT = re.compile(r"drone([1-9][0-9]*)")
MAX_ROBOTS = 30  # the WiFi medium's stations
PHASE_KEYS = {"name", "seconds", "robots", "link", "weight"}
SHIPPED = Path(__file__).parent / "missions"  # the package's own: standard, small


def robot_index(name: str) -> int:
    """``droneK`` -> K; ValueError for any other name."""
    match = ROBOT.fullmatch(name)
    if match is None or int(match.group(1)) > MAX_ROBOTS:
        raise ValueError(f"unknown robot {name!r}: robots are drone1 .. drone{MAX_ROBOTS}")
    return int(match.group(1))


@dataclass(frozen=True)
class Phase:
    """One phase as it is lived: who flies, every robot's link share and weight (the
    ones set by earlier phases included), from ``start`` (seconds into the mission)."""

    name: str
    start: float
    seconds: float
    robots: tuple[int, ...]
    link: Mapping[int, float] = field(default_factory=dict)  # robot -> share; absent: 1
    weight: Mapping[int, float] = field(default_factory=dict)  # robot -> w; absent: 1

    @property
    def end(self) -> float:
        return self.start + self.seconds

    def weight_of(self, robot: int) -> float:
        return self.weight.get(robot, 1.0)

    def link_of(self, robot: int) -> float:
        return self.link.get(robot, 1.0)

    def conditions(self) -> tuple[tuple[int, ...], tuple[tuple[int, float], ...],
                                  tuple[tuple[int, float], ...]]:
        """What a fixed rate is tuned to: who flies, their links and weights."""
        return (self.robots, tuple(sorted((r, s) for r, s in self.link.items()
                                          if r in self.robots and s != 1.0)),
                tuple(sorted((r, w) for r, w in self.weight.items()
                             if r in self.robots and w != 1.0)))


@dataclass(frozen=True)
class Mission:
    """Phases back to back, from 0 to ``duration``."""

    name: str
    phases: tuple[Phase, ...]

    @property
    def duration(self) -> float:
        return self.phases[-1].end

    @property
    def robots(self) -> tuple[int, ...]:
        """Every robot that flies at some point, in order."""
        return tuple(sorted({r for phase in self.phases for r in phase.robots}))

    def largest(self) -> Phase:
        """The first phase with the most robots (a throttle tuned for the largest N)."""
        return max(self.phases, key=lambda phase: len(phase.robots))

    def phase_at(self, t: float) -> Phase:
        """The phase flying at ``t`` seconds into the mission (the last one after it)."""
        return next((p for p in self.phases if t < p.end), self.phases[-1])


def _number(value: Any, where: str, *, low: float, low_open: bool) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) \
            or not math.isfinite(value) or value < low or (low_open and value == low):
        bound = f"> {low:g}" if low_open else f">= {low:g}"
        raise ValueError(f"{where} must be a number {bound}, got {value!r}")
    return float(value)


def _robots(value: Any, where: str) -> tuple[int, ...]:
    if isinstance(value, int) and not isinstance(value, bool):
        if not 1 <= value <= MAX_ROBOTS:
            raise ValueError(f"{where}.robots must be 1 .. {MAX_ROBOTS}, got {value}")
        return tuple(range(1, value + 1))
    if isinstance(value, list) and value and all(isinstance(v, str) for v in value):
        robots = [robot_index(v) for v in value]
        if len(set(robots)) != len(robots):
            raise ValueError(f"{where}.robots names a robot twice: {value}")
        return tuple(sorted(robots))
    raise ValueError(f"{where}.robots must be a count >= 1 or a list of robot names, "
                     f"got {value!r}")


def _settings(value: Any, where: str, flying: tuple[int, ...], *, low: float,
              low_open: bool, high: float = math.inf) -> dict[int, float]:
    if not isinstance(value, dict):
        raise ValueError(f"{where} must be a table of robot = number, got {value!r}")
    out = {}
    for name, number in value.items():
        robot = robot_index(name)
        if robot not in flying:
            raise ValueError(f"{where}: {name} does not fly in this phase")
        out[robot] = _number(number, f"{where}.{name}", low=low, low_open=low_open)
        if out[robot] > high:
            raise ValueError(f"{where}.{name} must be at most {high:g}, got {number!r}")
    return out


def parse_mission(data: Mapping[str, Any], name: str = "mission") -> Mission:
    """A mission from the TOML's tables (see the module); ValueError names what is wrong."""
    unknown = sorted(set(data) - {"name", "phase"})
    if unknown:
        raise ValueError(f"unknown field {unknown[0]!r}: a mission has name and [[phase]]")
    raw = data.get("phase")
    if not isinstance(raw, list) or not raw:
        raise ValueError("a mission needs at least one [[phase]]")
    phases: list[Phase] = []
    link: dict[int, float] = {}
    weight: dict[int, float] = {}
    start = 0.0
    for number, table in enumerate(raw, start=1):
        where = f"phase {number}"
        extra = sorted(set(table) - PHASE_KEYS)
        if extra:
            raise ValueError(f"{where}: unknown field {extra[0]!r} (fields: "
                             f"{', '.join(sorted(PHASE_KEYS))})")
        if "robots" not in table:
            raise ValueError(f"{where} has no robots")
        seconds = _number(table.get("seconds"), f"{where}.seconds", low=0.0, low_open=True)
        robots = _robots(table["robots"], where)
        link.update(_settings(table.get("link", {}), f"{where}.link", robots, low=0.0,
                              low_open=True, high=1.0))
        weight.update(_settings(table.get("weight", {}), f"{where}.weight", robots, low=0.0,
                                low_open=True))
        label = table.get("name", f"phase {number}")
        if not isinstance(label, str):
            raise ValueError(f"{where}.name must be text, got {label!r}")
        phases.append(Phase(label, start, seconds, robots, dict(link), dict(weight)))
        start += seconds
    title = data.get("name", name)
    return Mission(str(title), tuple(phases))


def load_mission(path: Path) -> Mission:
    """``path`` read and checked; ValueError (one line, naming the file) if it is not a
    mission."""
    try:
        data = tomllib.loads(path.read_text())
        return parse_mission(data, path.stem)
    except OSError as exc:
        raise ValueError(f"{path}: cannot read it ({exc.strerror})") from None
    except (tomllib.TOMLDecodeError, ValueError) as exc:
        raise ValueError(f"{path}: {exc}") from None


def shipped_text(name: str) -> str:
    """The file of a mission shipped with the package (``missions/<name>.toml``)."""
    return (SHIPPED / f"{name}.toml").read_text()


def shipped_names() -> tuple[str, ...]:
    return tuple(sorted(path.stem for path in SHIPPED.glob("*.toml")))


def mission_named(text: str) -> Mission:
    """A shipped mission by its name, else the mission file at path ``text``."""
    if text in shipped_names():
        return parse_mission(tomllib.loads(shipped_text(text)), text)
    return load_mission(Path(text))
