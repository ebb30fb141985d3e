"""Undeclaring Zenoh entities through one typed door (the stubs leave ``undeclare``
unannotated, which ``mypy --strict`` refuses to call directly)."""

from __future__ import annotations

from typing import Protocol


class Declared(Protocol):
    def undeclare(self) -> None: ...


def undeclare(*entities: Declared) -> None:
    """Undeclare in the order given."""
    for entity in entities:
        entity.undeclare()
