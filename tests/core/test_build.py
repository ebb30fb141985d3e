"""The build a run of the core's tests asked for is the one it tests (``make test``
runs them, and the transport's poll path's, on a mypyc-compiled copy too: a failed
build must not pass as Python)."""

from __future__ import annotations

import os

import pytest

from wiswarm_zenoh.core import COMPILED
from wiswarm_zenoh.transport import leader_node, links, outlets, steady_gets


def test_the_build_asked_for_is_the_one_tested() -> None:
    asked = os.environ.get("WISWARM_CORE_BUILD")
    if asked is None:
        pytest.skip("no build asked for (WISWARM_CORE_BUILD): whichever is installed")
    assert asked in ("pure", "compiled")
    assert (asked == "compiled") == COMPILED
    for module in (leader_node, links, outlets, steady_gets):  # setup.POLL_PATH
        assert module.__file__ is not None
        assert (asked == "compiled") == (not module.__file__.endswith(".py")), module
