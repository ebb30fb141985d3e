"""The command line of the benchmarks that run the stationary study (bench_testbed.py
over the tbf channel, bench_wifi.py over ns-3's WiFi): the study's flags as ``wiswarm
experiment testbed`` takes them, at a benchmark's defaults (short runs), and a machine
that cannot build the channel refused in one line, exit 2, as the CLI does."""

from __future__ import annotations

import argparse
from pathlib import Path

from wiswarm_zenoh.cli.experiment import add_study_arguments
from wiswarm_zenoh.options import OneLineParser, UsageError, require_testbed


def study_parser(script: str, doc: str, ns: tuple[int, ...]) -> argparse.ArgumentParser:
    """The benchmark ``script``'s parser (described by the first line of its ``doc``)."""
    parser = OneLineParser(prog=Path(script).name, description=doc.splitlines()[0])
    add_study_arguments(parser, ns, duration=10.0, warmup=4.0)
    return parser


def parse_on_testbed(parser: argparse.ArgumentParser) -> argparse.Namespace:
    """The flags, once this machine is known to build the channel (root, Linux)."""
    args = parser.parse_args()
    try:
        require_testbed()
    except UsageError as exc:
        parser.exit(2, f"{parser.prog}: {exc}\n")
    return args
