"""Command-line pieces for anything that builds the emulated channel (the ``testbed``
commands, the experiments, applications' own runs): its flags and the check that this
machine can build it."""

from __future__ import annotations

import argparse
import re

from wiswarm_zenoh.options.arguments import RATE, TIME, ArgType, positive_int
from wiswarm_zenoh.testbed import Channel, ChannelSpec, TestbedUnavailable, check_available
from wiswarm_zenoh.testbed.wifi_spec import MAX_STATIONS, STANDARDS, WifiSpec
from wiswarm_zenoh.usage import UsageError

_SIZE = re.compile(r"^\s*([0-9]+)\s*(b|k|kb|m|mb)?\s*$", re.IGNORECASE)
_SIZE_UNITS = {None: 1, "b": 1, "k": 1024, "kb": 1024, "m": 1024**2, "mb": 1024**2}


def parse_size(text: str) -> int:
    """``32kb`` -> 32768 bytes, in tc's spelling (k/kb = 1024 bytes, m/mb = 1024**2)."""
    found = _SIZE.match(text)
    if found is None:
        raise ValueError(f"size {text!r} is not a size: write it like 32kb or 40000 (bytes)")
    unit = found.group(2).lower() if found.group(2) else None
    return int(found.group(1)) * _SIZE_UNITS[unit]


def _run_id(text: str) -> str:
    """A channel's run id, as ``Channel`` takes it for a name (nothing is built)."""
    Channel(name=text)
    return text


RUN_ID = ArgType("run id", _run_id)
SIZE = ArgType("size", parse_size)


def require_testbed() -> None:
    """One line and exit 2 where namespaces cannot be built."""
    try:
        check_available()
    except TestbedUnavailable as exc:
        raise UsageError(str(exc)) from None


def channel_spec(args: argparse.Namespace) -> ChannelSpec:
    """The channel that ``add_channel_arguments``' flags describe (UsageError if bad)."""
    try:
        return ChannelSpec(rate_bps=args.rate, queue_s=args.queue,
                           down_rate_bps=args.down_rate, burst_bytes=args.burst)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def add_rates(parser: argparse.ArgumentParser, rate_required: bool) -> None:
    """--rate (required for `testbed set`, where it is the change) and --down-rate."""
    parser.add_argument("--rate", type=RATE, required=rate_required,
                        default=None if rate_required else 20_000_000, metavar="RATE",
                        help="the shared uplink's rate, followers -> leader, in tc's "
                             "spelling (20mbit, 500kbit)" +
                             ("" if rate_required else "; default 20mbit"))
    parser.add_argument("--down-rate", type=RATE, metavar="RATE",
                        help="the downlink's rate, leader -> followers (polls and control); "
                             "default: as --rate")


def add_channel_arguments(parser: argparse.ArgumentParser) -> None:
    """The channel's shape: --rate, --down-rate, --queue, --burst (``channel_spec``)."""
    add_rates(parser, rate_required=False)
    parser.add_argument("--queue", type=TIME, default=0.2,
                        metavar="TIME", help="how long a packet may wait in each direction's "
                        "queue before tail drop (tbf latency), e.g. 200ms; default 200ms")
    parser.add_argument("--burst", type=SIZE, default=32 * 1024,
                        metavar="SIZE", help="the token bucket's size: bytes sent back to back "
                        "at line speed after a pause, at least one MTU packet, e.g. 32kb; "
                        "default 32kb")


def _wifi_mode(text: str) -> str:
    """An ns-3 WifiMode this project knows the rate of (WifiSpec's own check)."""
    if not text:
        raise ValueError("data rate '': use ErpOfdmRate<R>Mbps (802.11g) or HtMcs0..HtMcs7 "
                         "(802.11n)")
    standard = "80211n" if text.startswith("Ht") else "80211g"
    WifiSpec(standard=standard, data_mode=text)
    return text


WIFI_MODE = ArgType("data rate", _wifi_mode)


def add_medium_arguments(parser: argparse.ArgumentParser, stations: bool) -> None:
    """--medium tbf|wifi and the WiFi medium's shape (``wifi_spec``); ``stations``: a
    --stations flag too (a study takes its stations from its largest N)."""
    parser.add_argument("--medium", choices=("tbf", "wifi"), default="tbf",
                        help="tbf: a shaped FIFO link (default); wifi: ns-3's 802.11 at "
                             "2.4 GHz in real time, an access point for the leader side "
                             "and a station per follower")
    if stations:
        parser.add_argument("--stations", type=positive_int(MAX_STATIONS), default=4,
                            metavar="N",
                            help=f"wifi: stations, one per follower (1-{MAX_STATIONS}); "
                                 "default 4")
    add_wifi_arguments(parser)


def add_wifi_arguments(parser: argparse.ArgumentParser) -> None:
    """The WiFi medium's shape, ns-3's: --standard, --data-rate, --hard-limit
    (``wifi_of``), for whatever runs over it (``--medium wifi``, bench_wifi.py)."""
    parser.add_argument("--standard", choices=STANDARDS, default="80211g",
                        help="wifi: the 802.11 standard; default 80211g")
    parser.add_argument("--data-rate", type=WIFI_MODE, metavar="MODE",
                        help="wifi: the data rate, an ns-3 WifiMode (ErpOfdmRate24Mbps, "
                             "HtMcs7); default the standard's: 24 Mbit/s for g, MCS 7 for n")
    parser.add_argument("--hard-limit", type=TIME, default=0.1, metavar="TIME",
                        help="wifi: the largest lag of the simulation behind real time "
                             "before the run fails loudly; default 100ms")


def wifi_spec(args: argparse.Namespace, stations: int) -> WifiSpec | None:
    """The WiFi medium ``add_medium_arguments``' flags describe, None for tbf
    (UsageError if bad)."""
    return wifi_of(args, stations) if args.medium == "wifi" else None


def wifi_of(args: argparse.Namespace, stations: int) -> WifiSpec:
    """The WiFi medium ``add_wifi_arguments``' flags describe (UsageError if bad)."""
    try:
        return WifiSpec(stations=stations, standard=args.standard, data_mode=args.data_rate,
                        hard_limit_ms=args.hard_limit * 1e3)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
