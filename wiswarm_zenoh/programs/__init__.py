"""Whole programs on the middleware: router, leader and follower processes as ``wiswarm``
runs them (``runners``), the process group and swarm demo (``demo``), live tables and
plots (``report``), synthetic frames and the fixed-rate ticker, Zenoh's log, and how a
process that held sessions ends (``exit_without_finalizing``)."""

from wiswarm_zenoh.programs.demo import Children
from wiswarm_zenoh.programs.process_exit import exit_without_finalizing
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
    "exit_without_finalizing",
    "run_router",
    "wait_until_stopped",
]
