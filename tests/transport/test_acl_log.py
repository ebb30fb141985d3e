"""Access control's trace log reduced to its refusals (lines as Zenoh 1.10 writes them)."""

from __future__ import annotations

from wiswarm_zenoh.programs.acl_log import TABLE_ROWS, DenialFilter

HEAD = (b"\x1b[2m2026-11-23T11:35:12.048846Z\x1b[0m \x1b[35mTRACE\x1b[0m rx-0 ThreadId(08) "
        b"\x1b[2mzenoh::net::routing::interceptor::access_control\x1b[0m\x1b[2m:\x1b[0m ")
F2 = b"84a32dcc2615176832099298f74274be"
FACE = b"Interface(lo)+CertCommonName(f2)+Transport(Tls)+" + F2


def _decision(verdict: bytes, message: bytes, key: bytes, cached: bool = False) -> bytes:
    who = b"Using cached result: " + F2 if cached else F2 + b" on " + FACE
    return HEAD + who + b" is " + verdict + b" to " + message + b" (ingress) on " + key + b"\n"


def test_refusals_are_shown_once_each_and_allowed_messages_and_tables_not_at_all() -> None:
    log = [
        HEAD + b"ACL (ingress): caching permissions for `wiswarm/S/f1/update` ...\n",
        *[_decision(b"unauthorized", b"Query", b"wiswarm/S/f1/update")] * TABLE_ROWS,
        _decision(b"unauthorized", b"Declare Queryable", b"wiswarm/S/f1/update", cached=True),
        _decision(b"authorized", b"Declare Subscriber", b"wiswarm/S/control", cached=True),
        _decision(b"authorized", b"Put", b"wiswarm/S/f2/update"),
        _decision(b"unauthorized", b"Put", b"wiswarm/S/control"),
        b"wiswarm router: listening on tls/127.0.0.1:7447\n",
    ]
    denials = DenialFilter()
    shown = [line for line in map(denials.feed, log) if line is not None]
    assert shown == [
        b"2026-11-23T11:35:12.048846Z  WARN access control refused f2: Declare Queryable "
        b"(ingress) on wiswarm/S/f1/update\n",
        b"2026-11-23T11:35:12.048846Z  WARN access control refused f2: Put (ingress) on "
        b"wiswarm/S/control\n",
        b"wiswarm router: listening on tls/127.0.0.1:7447\n",
    ]


def test_declarations_held_back_on_their_way_out_are_not_refusals_to_show() -> None:
    """Routers pass every declaration to every router: a cloud's router keeps each site's
    from the others as a matter of course; a put held back still shows."""
    def egress(message: bytes, key: bytes) -> bytes:
        return _decision(b"unauthorized", message, key).replace(b"(ingress)", b"(egress)")

    denials = DenialFilter()
    shown = [denials.feed(line) for line in (
        egress(b"Declare Queryable", b"wiswarm/C/s1.uav1/update"),
        egress(b"Undeclare Subscriber", b"wiswarm/C/control"),
        egress(b"Liveliness Token", b"wiswarm/C/members/s1.uav1"),
        egress(b"Undeclare Liveliness Token", b"wiswarm/C/members/s1.uav1"),
        egress(b"Put", b"wiswarm/C/s1.uav1/fresh"))]
    assert shown == [None] * 4 + [b"2026-11-23T11:35:12.048846Z  WARN access control "
                                  b"refused f2: Put (egress) on wiswarm/C/s1.uav1/fresh\n"]


def test_a_node_without_tls_at_a_tls_endpoint_is_named_once_whatever_rustls_calls_it() -> None:
    corrupt = (b"2026-11-27T15:59:21.301430Z  WARN acc-0 ThreadId(05) zenoh_link_tls::unicast: "
               b"received corrupt message of type %s. Hint: increase the system open file "
               b"limit.\n")
    denials = DenialFilter()
    shown = [denials.feed(corrupt % kind) for kind in
             (b"UnknownProtocolVersion", b"UnknownProtocolVersion", b"InvalidContentType")]
    assert shown[0] is not None and b"without TLS" in shown[0]
    assert shown[1:] == [None, None]  # said once
    assert DenialFilter().feed(corrupt % b"InvalidContentType") == shown[0]
