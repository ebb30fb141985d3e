"""A leader's weights given on the command line (``wiswarm leader --weight MEMBER=W``,
repeatable): each member's application weight from the moment it joins, refused in one
line before anything starts."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from wiswarm_zenoh.options.arguments import ArgType, finite_float, node_name
from wiswarm_zenoh.transport.weight_settings import PRESET_GRACE
from wiswarm_zenoh.usage import UsageError

_MEMBER = node_name("member", follower=True)
_WEIGHT = finite_float(0.0)


def _member_weight(text: str) -> tuple[str, float]:
    """``MEMBER=W``: a follower id (the last ``=`` ends it) and a finite number >= 0."""
    member, sep, value = text.rpartition("=")
    if not sep or not member:
        raise ValueError(f"expected MEMBER=W (a member and its weight, e.g. uav3=4), "
                         f"got {text[:60]!r}")
    try:
        _MEMBER.parse(member)
        return member, _WEIGHT.parse(value)
    except ValueError as exc:
        raise ValueError(f"{text[:60]!r}: {exc}") from None


MEMBER_WEIGHT = ArgType("member=weight", _member_weight)


def add_weight_argument(parser: argparse.ArgumentParser) -> None:
    """``--weight MEMBER=W``, repeatable (its values: ``preset_weights``)."""
    parser.add_argument("--weight", metavar="MEMBER=W", action="append", type=MEMBER_WEIGHT,
                        help="wiswarm: MEMBER's application weight w (a number >= 0; "
                        "default 1), taken whenever MEMBER joins, as if its key "
                        "wiswarm/<swarm>/<member>/weight were set then; repeatable, once "
                        f"per member. A member that has not joined within {PRESET_GRACE:g} "
                        "s is named in one warning")


def preset_weights(given: Sequence[tuple[str, float]] | None) -> tuple[tuple[str, float], ...]:
    """The ``--weight`` values given, each member once (UsageError naming one twice)."""
    seen: dict[str, float] = {}
    for member, weight in given or ():
        if member in seen:
            raise UsageError(f"--weight {member} given twice ({seen[member]:g}, {weight:g}): "
                             "one weight per member")
        seen[member] = weight
    return tuple(seen.items())
