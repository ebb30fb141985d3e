"""What the ``wiswarm security`` commands that change a directory ``init`` wrote share."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from wiswarm_zenoh.options import UsageError

T = TypeVar("T")
RELOADED = ("running routers restart by themselves with their new files, one at a time "
            "(copy them to routers on other machines)")


def changed(out: Path, change: Callable[[Path], T]) -> tuple[Path, T]:
    """Run ``change`` on the directory ``init`` wrote (``out``); its problems in one line."""
    directory = out.resolve()
    try:
        return directory, change(directory)
    except FileNotFoundError as exc:
        raise UsageError(f"{exc.filename}: not found (run `wiswarm security init --out "
                         f"{out}` first)") from None
    except (ValueError, OSError, KeyError) as exc:
        raise UsageError(f"{directory}: {exc}") from None
