"""Tests marked ``testbed`` build real namespaces and qdiscs: they need root, ``ip`` and
``tc``, and are skipped, saying which is missing, where those are not available."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.testbed import TestbedUnavailable, check_available


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "testbed: needs root, ip and tc (the emulated channel)")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    try:
        check_available()
    except TestbedUnavailable as exc:
        skip = pytest.mark.skip(reason=f"testbed unavailable: {exc}")
        for item in items:
            if item.get_closest_marker("testbed") is not None:
                item.add_marker(skip)


from .relay_helpers import no_relay_thread_left  # noqa: E402,F401  (a fixture)
