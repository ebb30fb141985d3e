"""Which build of the core the tests run on: pure Python, or compiled by mypyc
(``make compiled``; ``make test`` runs the core's tests on both)."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.core import COMPILED

pure_python_only = pytest.mark.skipif(
    COMPILED, reason="looks inside the pure-Python core (monkeypatched module globals), "
    "which compiled code binds at build time")
