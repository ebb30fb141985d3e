"""``wiswarm security revoke NAME`` and ``wiswarm security list``: cut one robot, edge
leader, observer or site off, and see who is issued and who is revoked."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from wiswarm_zenoh.cli.security_directory import RELOADED, changed
from wiswarm_zenoh.options import ArgType, writable_dir
from wiswarm_zenoh.security.acl import MAX_COMMON_NAME
from wiswarm_zenoh.security.identities import Identity, identities
from wiswarm_zenoh.security.places import places
from wiswarm_zenoh.security.plan import load
from wiswarm_zenoh.security.revocation import SITE, RevocationList, Revoked
from wiswarm_zenoh.security.revoke import revoke
from wiswarm_zenoh.transport.keys import check_name

COLUMNS = ("name", "role", "site", "expires", "state")


def _common_name(text: str) -> str:
    """A name as ``list`` shows it: NAME, SITE/NAME, or a site."""
    parts = text.split("/")
    if len(parts) > 2 or len(text) > MAX_COMMON_NAME:
        raise ValueError(f"{text[:60]!r} is no NAME, SITE/NAME or SITE of at most "
                         f"{MAX_COMMON_NAME} characters")
    for part in parts:
        check_name(part, "name")
        if ":" in part:
            raise ValueError(f"name {text[:60]!r} must not contain :")
    return text


COMMON_NAME = ArgType("name", _common_name)


def _what(entry: Revoked) -> str:
    where = "" if entry.site is None or entry.kind == SITE else f" of site {entry.site}"
    serial = "" if entry.serial is None else f" (certificate serial {entry.serial})"
    return f"{entry.kind} {entry.name}{where}{serial}"


def _revoke(args: argparse.Namespace) -> int:
    directory, (entries, written) = changed(args.out, lambda d: revoke(d, args.name))
    more = f" and its {len(entries) - 1} identities" if entries[0].kind == SITE else ""
    files = ", ".join(str(path.relative_to(directory)) for path in written)
    print(f"wiswarm security: revoked {_what(entries[0])}{more} at {entries[0].when}; "
          f"rewrote {files}: {RELOADED}")
    return 0


def _row(identity: Identity, listed: RevocationList) -> tuple[str, ...]:
    expires = identity.expires()
    entry = listed.find(identity.name)
    state = "issued" if entry is None else f"revoked {entry.when}"
    return (identity.name, identity.role, identity.site or "-",
            "-" if expires is None else f"{expires:%Y-%m-%d}", state)


def _table(rows: list[tuple[str, ...]]) -> str:
    widths = [max(len(row[k]) for row in rows) for k in range(len(COLUMNS))]
    return "\n".join("  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True))
                     .rstrip() for row in rows)


def _list(args: argparse.Namespace) -> int:
    def read(directory: Path) -> tuple[list[Identity], RevocationList]:
        return identities(places(directory, load(directory))), RevocationList.load(directory)

    _, (everyone, listed) = changed(args.out, read)
    sites = [(e.name, SITE, e.site or "-", "-", f"revoked {e.when}")
             for e in listed.entries if e.kind == SITE]
    rows = [_row(identity, listed) for identity in everyone]
    print(_table([COLUMNS, *rows, *sites]))
    revoked = sum(row[4] != "issued" for row in rows)
    print(f"{len(rows) - revoked} issued, {revoked} revoked")
    return 0


def register_revocation(commands: Any) -> None:
    """``revoke`` and ``list``, under ``wiswarm security``."""
    cut = commands.add_parser(
        "revoke", help="cut a follower, edge leader, observer or site off: its routers "
        "refuse it, and end its session, once they restart with their rewritten files")
    cut.add_argument("--out", required=True, metavar="DIR", type=writable_dir(),
                     help="the directory init wrote")
    cut.add_argument("name", type=COMMON_NAME, help="a name as `wiswarm security list` "
                     "shows it (a site's nodes: SITE/NAME), or a site: all of it")
    cut.set_defaults(func=_revoke, needs="security")
    show = commands.add_parser("list", help="who is issued (name, role, site, expiry) and "
                               "who is revoked")
    show.add_argument("--out", required=True, metavar="DIR", type=writable_dir(),
                      help="the directory init wrote")
    show.set_defaults(func=_list, needs="security")
