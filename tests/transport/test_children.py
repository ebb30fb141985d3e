"""``Children``: processes started together, watched, and stopped on the way out."""

from __future__ import annotations

import multiprocessing
from multiprocessing.synchronize import Barrier

import pytest

from wiswarm_zenoh.programs.demo import Children
from wiswarm_zenoh.programs.runners import ReadySignal, StopSignal

from .helpers import WAIT


def _together(barrier: Barrier, stop: StopSignal, ready: ReadySignal) -> None:
    """Ready only once every child of the barrier has started: a one-by-one start
    (each waiting for the previous to be ready) cannot get there."""
    barrier.wait(WAIT)
    ready.set()
    stop.wait()


def _brief(stop: StopSignal, ready: ReadySignal) -> None:
    ready.set()


def _broken(stop: StopSignal, ready: ReadySignal) -> None:
    raise RuntimeError("no session for you")


def _until_stopped(stop: StopSignal, ready: ReadySignal) -> None:
    ready.set()
    stop.wait()


def test_children_started_without_waiting_come_up_together() -> None:
    ctx = multiprocessing.get_context("spawn")
    barrier = ctx.Barrier(3)
    with Children(ctx) as children:
        for name in ("a", "b", "c"):
            children.start(name, _together, barrier, wait=False)
        children.wait_ready(WAIT)
        assert all(children.alive(name) for name in ("a", "b", "c"))
    assert not any(children.alive(name) for name in ("a", "b", "c"))


def test_alive_and_join_tell_a_child_that_ended_from_one_that_runs() -> None:
    with Children(multiprocessing.get_context("spawn")) as children:
        children.start("brief", _brief)
        children.start("steady", _until_stopped)
        assert not children.join(0.2)  # "steady" runs until stopped
        assert not children.alive("brief")
        assert children.alive("steady")
    assert not children.alive("steady")
    assert children.join(0.0)


def test_a_child_that_dies_while_starting_is_named() -> None:
    with Children(multiprocessing.get_context("spawn")) as children:
        children.start("fine", _until_stopped, wait=False)
        children.start("broken", _broken, wait=False)
        with pytest.raises(RuntimeError, match="broken did not start"):
            children.wait_ready(WAIT)


def test_names_are_unique() -> None:
    with Children(multiprocessing.get_context("spawn")) as children:
        children.start("one", _brief)
        with pytest.raises(ValueError, match="already started"):
            children.start("one", _brief)

