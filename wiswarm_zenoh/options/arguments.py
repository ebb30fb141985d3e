"""Argument types shared by every ``wiswarm`` subcommand.

A bad value is refused while the flags are parsed, as one line naming the flag, before
any session, process or file exists. Ranges that a config object checks itself
(``LeaderConfig.alpha``, a spec's bounds) stay there: these types refuse what no config
sees coming (NaN, infinities, a wrong sign, a name the wire cannot carry, a path that
cannot be written). Each type has a ``kind``: tests/test_cli_contract.py picks the bad
values to try on a flag by it.
"""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Generic, TypeVar

from wiswarm_zenoh.core.config import InFlight
from wiswarm_zenoh.core.in_flight import MOST as MOST_IN_FLIGHT
from wiswarm_zenoh.core.messages import MAX_ID_BYTES
from wiswarm_zenoh.transport.keys import check_follower, check_name, check_robot
from wiswarm_zenoh.transport.zenoh_config import (
    PROTOCOLS,
    check_endpoint,
    check_host,
    split_host_port,
    split_key_value,
)
from wiswarm_zenoh.units import parse_rate, parse_seconds

T = TypeVar("T")
_NAME_MAX = 255  # bytes of one path component (Linux's NAME_MAX)


class ArgType(Generic[T]):
    """An argparse type from a parser raising ValueError, whose message is the one line."""

    def __init__(self, kind: str, parse: Callable[[str], T]) -> None:
        self.kind = kind
        self.parse = parse
        self.__name__ = kind  # argparse names the type by it in some messages

    def __call__(self, text: str) -> T:
        try:
            return self.parse(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None


def _in_range(value: float, text: str, lo: float, hi: float, lo_open: bool) -> None:
    """ValueError unless ``lo <(=) value <= hi``, in the words of the bounds given."""
    above = value > lo if lo_open else value >= lo
    if above and value <= hi:
        return
    low = f"> {lo:g}" if lo_open else f">= {lo:g}"
    if hi == math.inf:
        raise ValueError(f"must be {low}, got {text}")
    if lo == -math.inf:
        raise ValueError(f"must be <= {hi:g}, got {text}")
    raise ValueError(f"must be in {'(' if lo_open else '['}{lo:g}, {hi:g}], got {text}")


def finite_float(lo: float = -math.inf, hi: float = math.inf, *,
                 lo_open: bool = False) -> ArgType[float]:
    """A finite number in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``): never NaN or inf."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise ValueError(f"expected a number, got {text!r}") from None
        if not math.isfinite(value):
            raise ValueError(f"expected a finite number, got {text!r}")
        _in_range(value, text, lo, hi, lo_open)
        return value

    return ArgType("float", parse)


def positive_float(hi: float = math.inf) -> ArgType[float]:
    """A finite number in ``(0, hi]``."""
    return finite_float(0.0, hi, lo_open=True)


def integer(lo: int | None = None, hi: int | None = None) -> ArgType[int]:
    """A whole number in ``[lo, hi]`` (either bound may be left open)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise ValueError(f"expected a whole number, got {text!r}") from None
        _in_range(value, text, -math.inf if lo is None else lo,
                  math.inf if hi is None else hi, False)
        return value

    return ArgType("int", parse)


def positive_int(hi: int | None = None) -> ArgType[int]:
    """A whole number >= 1 (and <= ``hi``)."""
    return integer(1, hi)


def listed(item: ArgType[T], example: str) -> ArgType[tuple[T, ...]]:
    """A comma-separated list of ``item``; the first bad one is named."""
    def parse(text: str) -> tuple[T, ...]:
        values = []
        for part in text.split(","):
            try:
                values.append(item.parse(part.strip()))
            except ValueError as exc:
                raise ValueError(f"expected a list like {example}: {exc}") from None
        return tuple(values)

    return ArgType(f"{item.kind} list", parse)


def one_of(choices: tuple[str, ...]) -> ArgType[str]:
    """One of ``choices`` (for lists of them: argparse's ``choices`` takes single values)."""
    def parse(text: str) -> str:
        if text not in choices:
            raise ValueError(f"{text[:60]!r} is not one of {', '.join(choices)}")
        return text

    return ArgType("choice", parse)


def float_range(item: ArgType[float]) -> ArgType[tuple[float, float]]:
    """``LO:HI``, two ``item`` values with LO <= HI."""
    def parse(text: str) -> tuple[float, float]:
        lo_text, sep, hi_text = text.partition(":")
        if not sep:
            raise ValueError(f"expected LO:HI, got {text!r}")
        lo, hi = item.parse(lo_text), item.parse(hi_text)
        if lo > hi:
            raise ValueError(f"expected LO <= HI, got {text!r}")
        return lo, hi

    return ArgType("range", parse)


def node_name(what: str, follower: bool = False, most: int = MAX_ID_BYTES,
              robot: bool = False) -> ArgType[str]:
    """A name that goes in a key and on the wire: one key chunk of at most ``most``
    UTF-8 bytes (a follower id: not one of the swarm's reserved words either; a robot's
    id: nor with the ``~`` that names its streams)."""
    def parse(text: str) -> str:
        if robot:
            check_robot(text)
        elif follower:
            check_follower(text)
        else:
            check_name(text, what)
        size = len(text.encode("utf-8", "replace"))
        if size > most:
            raise ValueError(f"{what} is {size} UTF-8 bytes long, at most {most}")
        return text

    return ArgType("name", parse)


def _host_port(text: str) -> str:
    split_host_port(text)
    return text


def host_port() -> ArgType[str]:
    """``HOST:PORT`` of a socket: checked, kept as written."""
    return ArgType("host:port", _host_port)


def host_name() -> ArgType[str]:
    """A host name or address of another machine (not resolved here)."""
    return ArgType("host", lambda text: check_host(text, resolve=False))


def _path(text: str) -> Path:
    if not text:
        raise ValueError("expected a path, got ''")
    path = Path(text)
    if any(len(os.fsencode(part)) > _NAME_MAX for part in path.parts):
        raise ValueError(f"{text[:40]}...: a name in it is over {_NAME_MAX} bytes")
    return path


def _check_writable_dir(directory: Path, text: str) -> None:
    if not directory.exists():
        raise ValueError(f"cannot write {text}: no directory {directory}")
    if not directory.is_dir():
        raise ValueError(f"cannot write {text}: {directory} is not a directory")
    if not os.access(directory, os.W_OK | os.X_OK):
        raise ValueError(f"cannot write {text}: permission denied in {directory}")


def _writable_file(text: str) -> str:
    path = _path(text)
    if path.is_dir():
        raise ValueError(f"{text} is a directory, not a file")
    _check_writable_dir(path.parent, text)
    if path.exists() and not os.access(path, os.W_OK):
        raise ValueError(f"cannot write {text}: permission denied")
    return text


def _writable_dir(text: str) -> Path:
    path = _path(text)
    if path.exists() and not path.is_dir():
        raise ValueError(f"{text} exists and is not a directory")
    existing = next(p for p in (path, *path.parents) if p.exists())
    _check_writable_dir(existing, text)  # the directories missing below it can be made
    return path


def readable_file(what: str) -> ArgType[str]:
    """A file that exists and can be read (``what`` names it in the message)."""
    def parse(text: str) -> str:
        path = _path(text)
        if not path.is_file():
            raise ValueError(f"{what} {text}: no such file")
        if not os.access(path, os.R_OK):
            raise ValueError(f"{what} {text}: permission denied")
        return text

    return ArgType("readable file", parse)


def writable_file() -> ArgType[str]:
    """A file to (over)write, in a directory that exists: refused before anything runs,
    not as a traceback when the run opens it."""
    return ArgType("file", _writable_file)


def writable_dir() -> ArgType[Path]:
    """An output directory: one that exists and is writable, or can be made (mkdir -p)."""
    return ArgType("dir", _writable_dir)


# Flags of several subcommands.
SEED = integer(0)  # numpy's generators take no negative seed
RATE = ArgType("rate", parse_rate)  # a link's, in tc's spelling: 20mbit
TIME = ArgType("time", parse_seconds)  # in tc's spelling: 200ms
COUNTS = listed(positive_int(), "2,4,8")  # numbers of UAVs


def _polls_in_flight(text: str) -> InFlight:
    return "auto" if text.strip() == "auto" else positive_int(MOST_IN_FLIGHT).parse(text)


IN_FLIGHT = ArgType("int", _polls_in_flight)  # --in-flight K, or auto
IN_FLIGHTS = listed(IN_FLIGHT, "1,6,auto")
FRAME_RATES = listed(positive_float(), "1,3,5")  # frames per second
PROBABILITIES = float_range(finite_float(0.0, 1.0))


def _listen_endpoint(endpoint: str) -> str:
    return check_endpoint(endpoint, listen=True)


def _key_value(item: str) -> str:
    split_key_value(item)
    return item


CONNECT_ENDPOINT = ArgType("endpoint", check_endpoint)
LISTEN_ENDPOINT = ArgType("endpoint", _listen_endpoint)
KEY_VALUE = ArgType("key:value", _key_value)  # Zenoh judges the key and value later


def add_zenoh_arguments(parser: argparse.ArgumentParser, modes: Sequence[str]) -> None:
    """The session flags: -m/-e/-l/-c, --cfg KEY:VALUE, --no-multicast-scouting,
    --shared-memory."""
    group = parser.add_argument_group("zenoh session")
    group.add_argument("-m", "--mode", choices=list(modes),
                       help="the Zenoh session mode (default router)" if "router" in modes
                       else "the Zenoh session mode (default: a client of the router -e "
                            "names; a peer without -e, or with -l)")
    group.add_argument("-e", "--connect", metavar="ENDPOINT", action="append", default=[],
                       type=CONNECT_ENDPOINT,
                       help="endpoint to connect to, e.g. tcp/HOST:7447 (repeatable; "
                            f"protocols: {', '.join(PROTOCOLS)})")
    group.add_argument("-l", "--listen", metavar="ENDPOINT", action="append", default=[],
                       type=LISTEN_ENDPOINT,
                       help="endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable; "
                            "port 0: any free one)")
    group.add_argument("-c", "--config", metavar="FILE", type=readable_file("config file"),
                       help="a Zenoh JSON5 configuration file")
    group.add_argument("--cfg", metavar="KEY:VALUE", action="append", default=[],
                       type=KEY_VALUE,
                       help="set one configuration value (VALUE is JSON5), "
                            "e.g. --cfg 'transport/unicast/max_links:2'")
    group.add_argument("--no-multicast-scouting", action="store_true",
                       help="do not discover peers and routers by multicast")
    group.add_argument("--shared-memory", action="store_true",
                       help="let Zenoh move payloads of 3 kB or more to processes on this "
                            "host through shared memory (default off: a router or leader "
                            "keeps every departed process's 17 MiB mapped)")


def add_rate_grid(parser: argparse.ArgumentParser, whose: str,
                  searched: str | None = None) -> None:
    """``--rates`` (the grid a baseline's best rate is searched on) and ``--fixed-rate``,
    as every study takes them; ``whose``: "the baselines'", "push's". With ``searched``
    (what ``--rates`` is for then) also ``--search``, fine by default, and ``--rates``
    is None unless given."""
    from wiswarm_zenoh.experiments.sweep import PAPER_RATES, SEARCHES  # nodes never load

    paper = ",".join(f"{r:g}" for r in PAPER_RATES)
    if searched is None:
        parser.add_argument("--rates", type=FRAME_RATES, default=PAPER_RATES,
                            help=f"{whose} rate grid for the best rate, fps (default the "
                            f"paper's: {paper})")
    else:
        parser.add_argument("--search", choices=SEARCHES, default=SEARCHES[0],
                            help=f"how {whose} best rate is found: fine, a golden-section "
                            "search on the rate from the channel's share of each follower "
                            "until the best rate's neighbours tried are within 5 %%; grid, "
                            "the best of --rates, as the paper's (default fine)")
        parser.add_argument("--rates", type=FRAME_RATES,
                            help=f"{searched}, fps (default the paper's: {paper})")
    parser.add_argument("--fixed-rate", type=positive_float(), default=50.0,
                        help=f"the fixed-rate {whose.removeprefix('the ')} fps (default 50)")
