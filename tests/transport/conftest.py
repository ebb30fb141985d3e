"""Fixtures: a free port, a loopback router, sessions closed after each test."""

from tests.transport.fixtures import port, recorder, router, sessions  # noqa: F401  (fixtures)
