"""Each node's user name and password, which its routers check (Zenoh's
``transport/auth/usrpwd``) before they open its session: what makes a name revocable.

Zenoh 1.10's TLS has no revocation list, and access control only filters messages: it
never refuses a session. A router's password file can: the router reads it when its
session opens, so a name left out of it is refused from the router's next start (which
``programs.router_reload`` makes by itself), and a session that name held ends then.

The user name is the node's certificate common name, and the routers' rules bind the
two (``rules.Group``): a password without the node's private key, or the key with
another node's password, gets nothing. So a router's password file, which holds the
passwords of its whole place, gives a thief no node's rights. The passwords live beside
the CA (``passwords.json``, its owner's only); each config holds its node's own, and
each place's routers share its password file (``users.txt``).
"""

from __future__ import annotations

import json
import os
import secrets
from collections.abc import Iterable
from pathlib import Path
from typing import Any

PASSWORDS = "passwords.json"  # beside the CA: every identity's password, by common name
USERS = "users.txt"  # a place's password file ("name:password" lines), beside its routers


def write_private(path: Path, data: bytes) -> Path:
    """``data`` in ``path``, readable by its owner only, in one step: a router watching
    the file never reads half of it."""
    temporary = path.with_name(f".{path.name}.tmp")
    descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(descriptor, "wb") as file:
        file.write(data)
    os.chmod(temporary, 0o600)  # an existing file keeps its mode through os.open
    os.replace(temporary, path)
    return path.resolve()


class Passwords:
    """Every identity's password, by common name."""

    def __init__(self, by_name: dict[str, str] | None = None) -> None:
        self._by_name = dict(by_name or {})

    @classmethod
    def load(cls, directory: Path) -> Passwords:
        """The passwords stored beside the CA in ``directory``."""
        path = directory / PASSWORDS
        if not path.exists():
            raise ValueError(f"{path}: not found (the directory was made before nodes had "
                             "passwords: make it again with init)")
        return cls(dict(json.loads(path.read_text())))

    def save(self, directory: Path) -> Path:
        text = json.dumps(self._by_name, indent=2, sort_keys=True) + "\n"
        return write_private(directory / PASSWORDS, text.encode())

    def issue(self, names: Iterable[str]) -> None:
        """New passwords for ``names`` (common names)."""
        for name in names:
            self._by_name[name] = secrets.token_urlsafe(24)

    def of(self, name: str) -> str:
        try:
            return self._by_name[name]
        except KeyError:
            raise ValueError(f"no password for {name!r} in {PASSWORDS}") from None

    def file(self, users: Iterable[str]) -> str:
        """A router's password file: one ``name:password`` line per user."""
        return "".join(f"{user}:{self.of(user)}\n" for user in users)

    def login(self, user: str) -> dict[str, Any]:
        """The ``transport/auth`` section of a node's config: how it logs in."""
        return {"usrpwd": {"user": user, "password": self.of(user)}}

    def router(self, user: str, users_file: Path) -> dict[str, Any]:
        """A router's: whom it lets in, and how it logs in where it dials (a router
        shows no user name to the router it is dialed by)."""
        return {"usrpwd": {**self.login(user)["usrpwd"], "dictionary_file": str(users_file)}}
