"""The revocation list: who was revoked, kept beside the CA (``revoked.json``).

Every router's rules and password file are written without the names on it, by
``revoke`` and by every later ``add-follower`` and ``add-site``; and a name on it is
never issued again (a new robot gets a new name: the old certificate still exists).
"""

from __future__ import annotations

import datetime
import json
from dataclasses import asdict, dataclass
from pathlib import Path

REVOKED = "revoked.json"
SITE = "site"  # the kind of a whole site's entry (each of its identities has its own too)


@dataclass(frozen=True)
class Revoked:
    """One revoked identity: its common name, its role (or ``site``), its site, when,
    and its certificate's serial number (hex; None for a site, or a certificate file
    that was gone)."""

    name: str
    kind: str
    site: str | None
    when: str  # ISO 8601, UTC
    serial: str | None


class RevocationList:
    """The entries of ``revoked.json`` (none if there is no such file)."""

    def __init__(self, entries: list[Revoked]) -> None:
        self.entries = entries

    @classmethod
    def load(cls, directory: Path) -> RevocationList:
        path = directory / REVOKED
        if not path.exists():
            return cls([])
        return cls([Revoked(**entry) for entry in json.loads(path.read_text())])

    def save(self, directory: Path) -> Path:
        path = directory / REVOKED
        path.write_text(json.dumps([asdict(e) for e in self.entries], indent=2) + "\n")
        return path.resolve()

    def names(self) -> frozenset[str]:
        """The revoked common names (and sites)."""
        return frozenset(entry.name for entry in self.entries)

    def find(self, name: str) -> Revoked | None:
        return next((entry for entry in self.entries if entry.name == name), None)

    def refuse(self, name: str, what: str) -> None:
        """ValueError if ``name`` (``what`` it would be) was revoked: a revoked name is
        never issued again, so that nobody brings a lost robot back by mistake."""
        entry = self.find(name)
        if entry is not None:
            raise ValueError(f"{what} {name!r} was revoked on {entry.when}: give the new "
                             "one another name")


def now() -> str:
    """This moment, as the list writes it."""
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
