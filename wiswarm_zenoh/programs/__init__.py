"""Whole programs on the middleware: router, leader and follower processes as ``wiswarm``
runs them (``runners``), the process group and swarm demo (``demo``), live tables and
plots (``report``), synthetic frames and the fixed-rate ticker, Zenoh's log."""

from wiswarm_zenoh.programs.demo import Children
from wiswarm_zenoh.programs.report import LiveTable
from wiswarm_zenoh.programs.runners import (
    SUPERVISION_PERIOD,
    ReadySignal,
    StopSignal,
    run_router,
    wait_until_stopped,
)
from wiswarm_zenoh.programs.ticker import Ticker

__all__ = [
    "SUPERVISION_PERIOD",
    "Children",
    "LiveTable",
    "ReadySignal",
    "StopSignal",
    "Ticker",
    "run_router",
    "wait_until_stopped",
]
