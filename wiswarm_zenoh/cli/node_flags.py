"""What the node commands share (``wiswarm router | leader | follower``): Zenoh's flags,
the swarm's name, config objects built into one-line usage errors, and the check of
flags that only some systems take."""

from __future__ import annotations

import argparse
from typing import Any

from wiswarm_zenoh.baselines import SYSTEMS as BASELINES
from wiswarm_zenoh.core import FollowerConfig
from wiswarm_zenoh.options import UsageError, add_zenoh_arguments, node_name, positive_float
from wiswarm_zenoh.programs.frames import FRAME_HEADER_BYTES
from wiswarm_zenoh.security.checks import check_swarm
from wiswarm_zenoh.transport.zenoh_config import LOCAL_ROUTER, SessionSpec

DEFAULT_SWARM = "swarm"
SYSTEMS = ("wiswarm", *BASELINES)


def add_common(parser: argparse.ArgumentParser, modes: tuple[str, ...]) -> None:
    add_zenoh_arguments(parser, modes)
    parser.add_argument("--duration", type=positive_float(), metavar="SECONDS",
                        help="stop after this long (default: until Ctrl-C)")


def add_swarm(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--swarm", default=DEFAULT_SWARM, type=node_name("swarm name"),
                        help=f"swarm name, a key chunk (default {DEFAULT_SWARM})")


def checked(build: Any, *args: Any, **kwargs: Any) -> Any:
    """Build a config object; its ValueError (naming the field) is the user's to fix."""
    try:
        return build(*args, **kwargs)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def session_spec(args: argparse.Namespace, default_mode: str) -> SessionSpec:
    spec = SessionSpec.from_args(args, default_mode,
                                 () if default_mode == "router" else (LOCAL_ROUTER,))
    spec.config()  # every flag checked before anything starts
    if getattr(args, "swarm", None) is not None:
        check_swarm(args.config, args.swarm)
    return spec


class Announce:
    """A ready signal that tells the user the node is up."""

    def __init__(self, text: str) -> None:
        self._text = text

    def set(self) -> None:
        print(self._text, flush=True)


def only_for(args: argparse.Namespace, only: dict[str, tuple[str, ...]]) -> None:
    """A flag given to a system that does not take it is the user's to fix."""
    for dest, systems in only.items():
        if getattr(args, dest) is not None and args.system not in systems:
            raise UsageError(f"--{dest.replace('_', '-')} is for --system "
                             f"{'/'.join(systems)}, not {args.system}")


def given(args: argparse.Namespace, *dests: str) -> dict[str, Any]:
    """The flags given, by name: the others keep their config's defaults."""
    return {dest: getattr(args, dest) for dest in dests if getattr(args, dest) is not None}


def check_frame_bytes(frame_bytes: int, config: FollowerConfig) -> None:
    if not FRAME_HEADER_BYTES <= frame_bytes <= config.max_update_bytes:
        raise UsageError(f"--frame-bytes must be in [{FRAME_HEADER_BYTES}, "
                         f"{config.max_update_bytes}], got {frame_bytes}")
