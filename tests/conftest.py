"""How the suite shares the machine when ``make test`` runs it on several workers
(pytest-xdist, ``-n``): each test goes to whichever worker is free, except the units
below, each run whole by one worker, one test after another:

- the testbed (``tests/testbed``): network namespaces, shaped links and ns-3, one at a
  time, as their rates and ages are measured;
- a module with a fixture built once for many of its tests (a venv, a run of the demo):
  split across workers, each would build it again. Such a module is found by its text
  (``@pytest.fixture(scope="module")`` and the like); a shared fixture it takes from
  elsewhere stops the run, naming it.

Run without ``-n``, none of this changes anything.

A suite started in the background ignores Ctrl-C (SIGINT), and so would every program it
starts: the tests that press Ctrl-C would wait on programs that cannot hear it. The
suite takes it back at its start, so that what it starts has it as at a terminal.
"""

from __future__ import annotations

import functools
import re
import signal
from pathlib import Path
from typing import Any

import pytest

TESTS = Path(__file__).parent
UNITS = ("tests/testbed/",)
SHARED = re.compile(r"@pytest\.fixture\(\s*scope\s*=\s*[\"'](class|module|package|session)")


if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


def unit(nodeid: str) -> str:
    """The unit a test runs in: one of UNITS, its module if that builds a fixture once,
    else the test alone."""
    module = nodeid.split("::")[0]
    return next((name for name in UNITS if nodeid.startswith(name)),
                module if _builds_once(module) else nodeid)


@functools.cache
def _builds_once(module: str) -> bool:
    path = TESTS.parent / module
    return path.is_file() and SHARED.search(path.read_text()) is not None


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    from xdist.scheduler import LoadScopeScheduling  # only ever called with xdist

    class ByUnit(LoadScopeScheduling):  # type: ignore[misc]
        """LoadScopeScheduling with ``unit`` for scopes (the largest units first)."""

        def _split_scope(self, nodeid: str) -> str:
            return unit(nodeid)

    return ByUnit(config, log)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """A test taking a fixture of a wider scope than a test's must be in a unit."""
    for item in items:
        info = getattr(item, "_fixtureinfo", None)
        shared = [name for name, defs in (info.name2fixturedefs.items() if info else ())
                  for d in defs if d.scope != "function"
                  and Path(d.func.__code__.co_filename).is_relative_to(TESTS)]
        if shared and unit(item.nodeid) == item.nodeid:
            raise pytest.UsageError(f"{item.nodeid}: its fixture {shared[0]} is built once "
                                    "for many tests: add its module or folder to UNITS in "
                                    "tests/conftest.py")
