"""Access control's trace log, reduced to what it refused: one line per refusal.

Zenoh 1.10 logs access-control decisions at trace level only, one line per message
allowed as well as refused: ``<zid> on <face> is (un)authorized to Put (ingress) on
<key>``, or, for a key a node declared on, ``Using cached result: <zid> is ...``. When a
node first declares something on a key, a table of its permissions there (every message
type in turn) follows ``caching permissions for `<key>` ``: what it *may* do, not what
it tried, so the table is dropped. The face names the certificate's common name, which
is remembered for the cached results, whose lines carry only the session id.

A declaration refused on its way out (egress) is dropped too: routers pass every
declaration to every router they are linked to, so a cloud's router keeps each site's
from the others (and from itself, what it does not need) as a matter of course; what a
node tried shows as an ingress refusal, and a message held back as a put, query or reply.
"""

from __future__ import annotations

import re

ANSI = re.compile(rb"\x1b\[[0-9;]*m")
DECISION = re.compile(
    rb"^(?P<time>\S+)\s.*?ThreadId\((?P<thread>\d+)\).*?access_control: "
    rb"(?P<cached>Using cached result: )?(?P<zid>[0-9a-f]+) (?:on (?P<face>\S+) )?"
    rb"is (?P<verdict>un)?authorized to (?P<message>.+) \((?P<flow>ingress|egress)\) "
    rb"on (?P<key>\S+)$"
)
TABLE = re.compile(rb"ThreadId\((?P<thread>\d+)\).*access_control: ACL \(\w+\): "
                   rb"caching permissions for `")
COMMON_NAME = re.compile(rb"CertCommonName\(([^)]*)\)")
ALLOWED = b" is authorized to "
QUIET = b"Access control is disabled"  # said at debug on every router without rules
# A client speaking plain TCP to a TLS listener (or the reverse): Zenoh's own line blames
# the open file limit, every 0.5 s; said once, in words that point at the cause. What
# rustls names depends on the plain message's first bytes (its length, which varies with
# the node's id): mostly InvalidContentType, UnknownProtocolVersion where the first byte
# happens to be a TLS record type.
WRONG_PROTOCOL = b"zenoh_link_tls::unicast: received corrupt message of type "
WRONG_PROTOCOL_SAID = (b"WARN a node reached this TLS endpoint without TLS (a tcp/ "
                       b"endpoint, or no certificates): give it tls/HOST:PORT and its "
                       b"config from wiswarm security (said once)\n")
DECLARED = (b"Subscriber", b"Queryable", b"Token")  # (un)declarations, tokens too
TABLE_ROWS = 9  # message types in a table: query, reply, put, delete, three declarations,
# liveliness query and liveliness subscriber (Zenoh 1.10)


class DenialFilter:
    """Feed Zenoh's log lines; get back the lines to show: refusals as one readable line
    each, a node without TLS at a TLS endpoint once, other log lines unchanged, allowed
    messages, permission tables and "access control is disabled" not at all."""

    def __init__(self) -> None:
        self._table_rows: dict[bytes, int] = {}  # by thread: rows of a table still to come
        self._names: dict[bytes, bytes] = {}  # session id -> certificate common name
        self._wrong_protocol_said = False

    def feed(self, line: bytes) -> bytes | None:
        if ALLOWED in line and not any(self._table_rows.values()):
            return None  # most lines, by far: a message let through (no table to count)
        if QUIET in line:
            return None
        if WRONG_PROTOCOL in line:
            said, self._wrong_protocol_said = self._wrong_protocol_said, True
            return None if said else WRONG_PROTOCOL_SAID
        plain = ANSI.sub(b"", line).rstrip(b"\r\n")
        decision = DECISION.match(plain)
        if decision is None:
            table = TABLE.search(plain)
            if table is None:
                return line
            self._table_rows[table["thread"]] = TABLE_ROWS
            return None
        if decision["face"] is not None and (name := COMMON_NAME.search(decision["face"])):
            self._names[decision["zid"]] = name[1]
        thread = decision["thread"]
        if not decision["cached"] and self._table_rows.get(thread):
            self._table_rows[thread] -= 1
            return None
        if not decision["verdict"] or (decision["flow"] == b"egress"
                                       and decision["message"].endswith(DECLARED)):
            return None
        who = self._names.get(decision["zid"], decision["zid"])
        return (b"%s  WARN access control refused %s: %s (%s) on %s\n"
                % (decision["time"], who, decision["message"], decision["flow"],
                   decision["key"]))
