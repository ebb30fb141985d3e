"""Link rates and queue times as people write them (``20mbit``, ``200ms``), in one place
for the testbed, the simulator's ``link`` channel and their command lines.

The spellings are ``tc``'s: a rate is bits per second with an optional ``kbit``,
``mbit`` or ``gbit`` suffix; a time is seconds with an optional ``ms``/``us``/``s``.
"""

from __future__ import annotations

import math
import re
from datetime import UTC, datetime

_RATE = re.compile(r"^\s*([0-9]*\.?[0-9]+)\s*(bit|kbit|mbit|gbit)?\s*$", re.IGNORECASE)
_RATE_UNITS = {None: 1, "bit": 1, "kbit": 10**3, "mbit": 10**6, "gbit": 10**9}
_TIME = re.compile(r"^\s*([0-9]*\.?[0-9]+)\s*(us|ms|s)?\s*$", re.IGNORECASE)
_TIME_UNITS = {None: 1.0, "s": 1.0, "ms": 1e-3, "us": 1e-6}
MIN_RATE_BPS = 8_000  # below 1 kB/s no frame of the paper's crosses in under a minute
MAX_RATE_BPS = 100 * 10**9


def parse_rate(text: str) -> int:
    """``20mbit`` -> 20_000_000 (bits per second); ValueError says what is wrong."""
    found = _RATE.match(text)
    if found is None:
        raise ValueError(f"rate {text!r} is not a rate: write it like 20mbit, 500kbit or "
                         "1gbit (bits per second)")
    unit = found.group(2).lower() if found.group(2) else None
    value = float(found.group(1)) * _RATE_UNITS[unit]
    if not MIN_RATE_BPS <= value <= MAX_RATE_BPS:
        raise ValueError(f"rate {text!r} must be between {format_rate(MIN_RATE_BPS)} and "
                         f"{format_rate(MAX_RATE_BPS)}")
    return round(value)


def parse_seconds(text: str) -> float:
    """``200ms`` -> 0.2 (seconds); a bare number is seconds; ValueError if not > 0."""
    found = _TIME.match(text)
    if found is None:
        raise ValueError(f"time {text!r} is not a time: write it like 200ms or 0.2s")
    unit = found.group(2).lower() if found.group(2) else None
    value = float(found.group(1)) * _TIME_UNITS[unit]
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"time {text!r} must be > 0")
    return value


def format_rate(bps: float) -> str:
    """20_000_000 -> ``20mbit``: the spelling ``tc`` and ``parse_rate`` take back."""
    for unit, scale in (("gbit", 10**9), ("mbit", 10**6), ("kbit", 10**3)):
        if bps >= scale and bps % scale == 0:
            return f"{bps // scale:g}{unit}"
    for unit, scale in (("mbit", 10**6), ("kbit", 10**3)):
        if bps >= scale:
            return f"{bps / scale:g}{unit}"
    return f"{bps:g}bit"


def format_epoch(epoch_us: int) -> str:
    """A leader's epoch (microseconds since the Unix epoch: when it took its role) as
    the UTC time it stands for, to the millisecond."""
    moment = datetime.fromtimestamp(epoch_us / 1e6, tz=UTC)
    return moment.strftime("%Y-%m-%d %H:%M:%S.") + f"{moment.microsecond // 1000:03d} UTC"
