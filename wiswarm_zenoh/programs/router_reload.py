"""A router that takes its changed files by itself, one router of a place at a time.

``wiswarm router -c FILE`` watches FILE and the files it names (its password file,
certificates and keys). Once they have changed and stayed so for one check, it closes
its session and opens it again in-process: Zenoh reads a router's rules and password
file only when its session opens (its admin space refuses to change them), and only a
new session refuses what its old one let in, so this is how what ``wiswarm security
revoke`` or ``add-follower`` rewrote takes effect, with no operator at the router.

Routers of one place must not restart together, or their nodes would have none to fail
over to. A router's config gives it its turn (``metadata/wiswarm/reload``: ``turn`` of
``of``), and it restarts only in the first half of its own second of every ``of``
seconds of the clock: router 0 of 2 in [0, 0.5) s of each 2 s, router 1 in [1, 1.5) s.
So two never restart within half a second of each other, whatever order their files
arrive in, as long as their clocks agree within a quarter of a second (NTP).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import zenoh

from wiswarm_zenoh.transport.tls_files import tls_files
from wiswarm_zenoh.transport.zenoh_config import SessionSpec
from wiswarm_zenoh.usage import UsageError

log = logging.getLogger(__name__)

TURN = 1.0  # seconds of the clock per router of a place: it restarts in the first half
# Seconds between closing and opening again. A router reopened at once on its port loses
# now and then what a router linked to it declared (Zenoh 1.10, on loopback: a site's
# liveliness tokens gone from the cloud's router after 4 to 10 restarts in 100; none in
# 200 with 50 ms between). Its nodes and routers try again 100 ms after losing it, so
# the pause costs them nothing.
REOPEN_AFTER = 0.05
PASSWORD_FILE = "transport/auth/usrpwd/dictionary_file"


@dataclass(frozen=True)
class Turn:
    """When a router may restart: router ``index`` of the ``of`` routers of its place."""

    index: int = 0
    of: int = 1

    def due(self, clock: float) -> bool:
        """Whether ``clock`` (seconds since the epoch) lies in this router's half-turn."""
        if self.of <= 1:
            return True
        phase = clock % (self.of * TURN) - self.index * TURN
        return 0 <= phase < TURN / 2


def turn_of(config: zenoh.Config) -> Turn:
    """The turn a config gives its router (its only turn if it gives none)."""
    metadata = json.loads(config.get_json("metadata"))  # free JSON: read whole
    ours = metadata.get("wiswarm") if isinstance(metadata, dict) else None
    found = ours.get("reload") if isinstance(ours, dict) else None
    if not isinstance(found, dict):
        return Turn()
    return Turn(int(found.get("turn", 0)), int(found.get("of", 1)))


def named_files(spec: SessionSpec, config: zenoh.Config) -> list[str]:
    """The config file and the files it names: what a change of is taken."""
    if spec.config_file is None:
        return []
    password_file = json.loads(config.get_json(PASSWORD_FILE))
    return [spec.config_file, *tls_files(config).values(),
            *([password_file] if isinstance(password_file, str) else [])]


def _digest(path: str) -> bytes | None:
    try:
        return hashlib.sha256(Path(path).read_bytes()).digest()
    except OSError:
        return None


class FileWatch:
    """Files, and whether they changed since they were taken and stayed so for a check
    (a file is written, then the next: a restart between them would be one too many)."""

    def __init__(self, paths: Sequence[str]) -> None:
        self.paths = list(paths)
        self._taken = self._seen = self._now()

    def _now(self) -> tuple[bytes | None, ...]:
        return tuple(map(_digest, self.paths))

    def settled_change(self) -> list[str]:
        """The files that changed, once nothing changed since the last check."""
        now = self._now()
        settled, self._seen = now == self._seen, now
        if not settled:
            return []
        return [p for p, a, b in zip(self.paths, self._taken, now, strict=True) if a != b]

    def take(self) -> None:
        """The files as they are now are the ones in use."""
        self._taken = self._seen = self._now()


class ReloadingRouter:
    """A router's session, opened again when its files change, in its turn."""

    def __init__(self, spec: SessionSpec) -> None:
        self._spec = spec
        self._open_one = contextlib.ExitStack()
        self.session = self._open()

    def _open(self) -> zenoh.Session:
        session = self._open_one.enter_context(self._spec.open())
        config = self._spec.config()
        self._watch = FileWatch(named_files(self._spec, config))
        self._turn = turn_of(config)
        return session

    def check(self) -> None:
        """Restart if the files changed and it is this router's turn."""
        changed = self._watch.settled_change()
        if changed and self._turn.due(time.time()):
            self._reload(changed)

    def _reload(self, changed: list[str]) -> None:
        old = self.session.zid()
        try:
            self._spec.config()  # checked before the running session goes
        except UsageError as exc:
            self._watch.take()  # tried again when they change again
            log.error("router %s: %s changed, not taken (%s): it runs on as it was", old,
                      ", ".join(changed), exc)
            return
        started = time.monotonic()
        self._open_one.close()
        time.sleep(REOPEN_AFTER)
        self.session = self._open()
        log.info("router %s: %s changed: restarted as %s in %.0f ms", old,
                 ", ".join(changed), self.session.zid(), 1e3 * (time.monotonic() - started))

    def close(self) -> None:
        self._open_one.close()
