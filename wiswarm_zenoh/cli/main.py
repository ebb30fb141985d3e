"""Entry point of the ``wiswarm`` console script.

Each subcommand group lives in its own module exposing ``register(subparsers)``, imported
by ``every_command``; registering loads no optional library (``wiswarm_zenoh.extras``),
and a command that always needs one says so with ``set_defaults(needs=EXTRA)``;
bad input ends with one line on stderr and exit code 2, returned by ``main`` (argparse's
exit included), so that callers in-process see the same code as the shell; so does a
command whose extra is not installed (``wiswarm_zenoh.extras``): its line says which.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable, Sequence
from typing import Any, NoReturn

from wiswarm_zenoh.extras import missing_extra, require
from wiswarm_zenoh.options import OneLineParser, UsageError
from wiswarm_zenoh.programs.process_exit import exit_without_finalizing
from wiswarm_zenoh.programs.router_watch import NoRouterReached
from wiswarm_zenoh.programs.runners import sigterm_as_ctrl_c
from wiswarm_zenoh.programs.zenoh_log import LOG_FORMAT, init_zenoh_log

Registrar = Callable[[Any], None]  # adds its subcommands to ``subparsers``, each with ``func``
NODE_COMMANDS = ("router", "leader", "follower")  # registered by ``cli.nodes``


def every_command() -> tuple[Registrar, ...]:
    """What ``wiswarm`` runs: each module's ``register(subparsers)``, imported here rather
    than with this module, so that a caller naming fewer (a test) starts quicker."""
    from wiswarm_apps.tracking import cli as tracking
    from wiswarm_zenoh.cli import (
        dashboard,
        experiment,
        nodes,
        recording,
        security,
        sim,
        testbed,
    )
    return (nodes.register, sim.register, testbed.register, experiment.register,
            security.register, dashboard.register, recording.register, tracking.register)


def command_of(argv: Sequence[str]) -> str | None:
    """The command ``argv`` names (its first word that is no option)."""
    return next((arg for arg in argv if not arg.startswith("-")), None)


def commands_for(argv: Sequence[str]) -> tuple[Registrar, ...]:
    """The commands to build a parser of for ``argv``: a node (router, leader, follower:
    what a robot runs, on a small computer) gets its own alone, so that it loads what
    nodes need and not the tracking app, the dashboard or ROS 2; anything else all."""
    if command_of(argv) in NODE_COMMANDS:
        from wiswarm_zenoh.cli import nodes
        return (nodes.register,)
    return every_command()


def build_parser(registrars: Sequence[Registrar] | None = None) -> argparse.ArgumentParser:
    """The parser of every command, or of those ``registrars`` add."""
    parser = OneLineParser(
        prog="wiswarm",
        description="WiSwarm: keep a swarm's information fresh by polling over Zenoh.",
    )
    parser.add_argument(
        "-v", "--verbose", action="count", default=0, help="more logging (-vv: debug)"
    )
    subparsers = parser.add_subparsers(
        dest="command", metavar="COMMAND", parser_class=OneLineParser
    )
    subparsers.required = True
    for register in every_command() if registrars is None else registrars:
        register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None,
         registrars: Sequence[Registrar] | None = None) -> int:
    """Run one command (``argv``, default the process's); its exit code."""
    argv = sys.argv[1:] if argv is None else argv
    try:
        return _run(argv, registrars)
    except ImportError as exc:  # the one place a missing extra is told, wherever it was met
        missing = missing_extra(exc)
        if missing is None:
            raise
        print(f"wiswarm {command_of(argv)}: {missing}", file=sys.stderr)
        return 2


def _run(argv: Sequence[str], registrars: Sequence[Registrar] | None) -> int:
    parser = build_parser(commands_for(argv) if registrars is None else registrars)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help (0), or a bad flag: its one line is written
        return exc.code if isinstance(exc.code, int) else 2
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format=LOG_FORMAT)
    if args.command != "router":  # which starts Zenoh's log itself, showing denials
        init_zenoh_log(args.verbose)
    if getattr(args, "needs", None) is not None:
        require(args.needs)  # before anything starts
    try:
        with sigterm_as_ctrl_c():  # a service manager's stop ends a node as Ctrl-C does
            code: int = args.func(args)
    except UsageError as exc:
        print(f"wiswarm {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except NoRouterReached:  # the node said so in its one line
        return 1
    except KeyboardInterrupt:
        return 130
    return code


def console() -> NoReturn:
    """The ``wiswarm`` script: ``main``, then an end without the interpreter's
    finalisation, which a Zenoh thread could otherwise crash (``process_exit``)."""
    exit_without_finalizing(main())


if __name__ == "__main__":
    console()
