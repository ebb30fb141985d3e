"""The optional libraries and the extra that installs each.

``pip install wiswarm-zenoh`` carries what a follower, a leader, a router and the API
need (a follower runs on a drone's companion computer); the rest comes by use, as an
extra. A library an extra brings is loaded only where that use starts, so a missing one
is found there and named, as one line: which extra to install.
"""

from __future__ import annotations

import importlib.util

# extra -> the import names of the libraries it installs (as pyproject.toml lists them);
# the first extra that lists a library is the one named when it is missing.
EXTRAS: dict[str, tuple[str, ...]] = {
    "dashboard": ("aiohttp",),
    "foxglove": ("foxglove",),
    "ros2": ("rosbags",),
    "security": ("cryptography",),
    "plots": ("matplotlib",),
    # the tracking demo: vision, MAVLink and plots, and it serves the dashboard and
    # Foxglove and speaks ROS 2, so it brings those extras too
    "tracking": ("cv2", "pymavlink", "matplotlib", "aiohttp", "foxglove", "rosbags"),
}


class MissingExtra(ImportError):
    """An optional library is not installed; the message says which extra brings it."""

    def __init__(self, extra: str, library: str) -> None:
        super().__init__(f"needs the {extra} extra: pip install 'wiswarm-zenoh[{extra}]'",
                         name=library)
        self.extra = extra


def extra_of(library: str) -> str | None:
    """The extra that installs ``library`` (an import name, dotted or not), or None."""
    top = library.partition(".")[0]
    return next((extra for extra, names in EXTRAS.items() if top in names), None)


def missing_extra(error: ImportError) -> MissingExtra | None:
    """``error`` as the extra to install, None if what failed is no optional library
    (a real bug, which keeps its traceback)."""
    if isinstance(error, MissingExtra):
        return error
    extra = extra_of(error.name or "")
    return None if extra is None else MissingExtra(extra, error.name or "")


def require(extra: str) -> None:
    """Raise ``MissingExtra`` now if a library of ``extra`` is missing: before a command
    starts processes or runs for minutes, not when it reaches the library."""
    for library in EXTRAS[extra]:
        if importlib.util.find_spec(library) is None:
            raise MissingExtra(extra, library)
