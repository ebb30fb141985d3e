"""The cells of the experiments' markdown tables: ages in ms, ratios, with a dash where
a run measured nothing, so every report writes a missing figure the same way."""

from __future__ import annotations

import math


def ms(seconds: float) -> str:
    """Seconds as whole milliseconds ("-" for NaN)."""
    return "-" if math.isnan(seconds) else f"{seconds * 1e3:.0f}"


def ratio(a: float, b: float) -> float:
    """a / b, NaN where either is not a finite measure or b is not > 0."""
    return a / b if b > 0 and math.isfinite(a) and math.isfinite(b) else math.nan


def times(value: float) -> str:
    """A ratio with two decimals ("-" for NaN)."""
    return "-" if math.isnan(value) else f"{value:.2f}"
