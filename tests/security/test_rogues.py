"""Each rogue is refused by the secured router: real sessions on loopback TLS."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any, cast

import pytest
import zenoh

from wiswarm_zenoh.ros2.graph import data_key
from wiswarm_zenoh.ros2.messages import message_class, ros_type, serialize
from wiswarm_zenoh.security import pki
from wiswarm_zenoh.security.acl import Roster
from wiswarm_zenoh.security.deploy import Plan, init

from .helpers import KEYS, SWARM, Inbox, Sessions, answer, flushed, replies, until


def _open_raw(config: dict[str, Any]) -> zenoh.Session:
    """Open with Zenoh alone: no check of ours stands between the rogue and the router."""
    return zenoh.open(zenoh.Config.from_json5(json.dumps(config)))


def _client(swarm: Path, name: str) -> dict[str, Any]:
    """``name``'s config as ``init`` wrote it (its password too)."""
    return dict(json.loads((swarm / f"{name}.json5").read_text().split("\n", 1)[1]))


def _endpoint(swarm: Path) -> str:
    text = (swarm / "leader.json5").read_text().split("\n", 1)[1]
    return str(json.loads(text)["connect"]["endpoints"][0])


def test_a_session_without_a_certificate_cannot_connect(swarm: Path,
                                                        router: zenoh.Session) -> None:
    config = _client(swarm, "leader")
    tls = config["transport"]["link"]["tls"]
    for key in ("connect_certificate", "connect_private_key", "enable_mtls"):
        del tls[key]
    with pytest.raises(zenoh.ZError, match="Unable to connect"):
        _open_raw(config)


def test_a_certificate_of_another_ca_is_refused(swarm: Path, router: zenoh.Session,
                                                tmp_path: Path) -> None:
    # It trusts the swarm's CA (so it accepts the router) and shows a certificate named
    # like a member, signed by a CA of its own: the router must refuse it.
    other = pki.new_authority("other", 1)
    cert, key = pki.issue(other, "leader", 1)
    cert_path, key_path = pki.write_pair(tmp_path, "forged", cert, key)
    config = _client(swarm, "leader")
    tls = config["transport"]["link"]["tls"]
    tls.update(connect_certificate=str(cert_path), connect_private_key=str(key_path))
    with pytest.raises(zenoh.ZError, match="Unable to connect"):
        _open_raw(config)


def test_no_plain_tcp_endpoint_is_open(swarm: Path, router: zenoh.Session) -> None:
    plain = _endpoint(swarm).replace("tls/", "tcp/")
    with pytest.raises(zenoh.ZError, match="Unable to connect"):
        _open_raw({"mode": "client", "connect": {"endpoints": [plain]},
                   "scouting": {"multicast": {"enabled": False}}})
    # Nor can the router be told to open one: its config allows TLS links only.
    config = json.loads((swarm / "router.json5").read_text().split("\n", 1)[1])
    config["listen"]["endpoints"] = ["tcp/127.0.0.1:0"]
    with pytest.raises(zenoh.ZError, match="Unsupported protocol: tcp"):
        _open_raw(config)


def test_a_follower_cannot_put_control(sessions: Sessions, router: zenoh.Session) -> None:
    leader, f1, f2 = (sessions.open(n) for n in ("leader", "f1", "f2"))
    control = Inbox(f1, KEYS.control)
    ack = answer(f2, KEYS.update("f2"), b"ack")
    until("f1's subscription reaches the leader",
          lambda: _put_and_check(leader, control, b"hello"))
    f2.put(KEYS.control, b"rogue")
    flushed(leader, "f2")
    leader.put(KEYS.control, b"marker")
    assert set(control.wait_for(b"marker")) == {b"hello"}
    ack.undeclare()


def test_a_follower_cannot_set_a_weight(sessions: Sessions, router: zenoh.Session) -> None:
    # The leader's side sets weights (a tool holding the leader's certificate); a
    # follower putting its own weight up would take the others' polls.
    leader, tool, f2 = (sessions.open(n) for n in ("leader", "leader", "f2"))
    weights = Inbox(leader, KEYS.all_weights)
    ack = answer(f2, KEYS.update("f2"), b"ack")
    until("the tool's weight reaches the leader",
          lambda: _put_and_check(tool, weights, b"2", KEYS.weight("f2")))
    f2.put(KEYS.weight("f2"), b"100")
    flushed(leader, "f2")
    tool.put(KEYS.weight("f2"), b"3")
    assert set(weights.wait_for(b"3")) == {b"2"}
    ack.undeclare()


def test_a_follower_cannot_set_a_weight_over_ros2(tmp_path: Path, port: int) -> None:
    # With --ros2 the leader hears weights on <ns>/<follower>/weight too: only its side
    # may put there, as on the weight key.
    endpoint = (f"tls/127.0.0.1:{port}",)
    init(tmp_path / "ros2", Plan(Roster(SWARM, "leader", ("f1", "f2"), ros2=(0, None)),
                                 listen=endpoint, connect=endpoint, days=1))
    sessions = Sessions(tmp_path / "ros2")
    try:
        sessions.open("router")
        leader, tool, f2 = (sessions.open(n) for n in ("leader", "leader", "f2"))
        kind = ros_type("std_msgs/msg/Float64")
        key = data_key(0, f"/wiswarm/{SWARM}/f2/weight", kind)
        weights = Inbox(leader, f"0/wiswarm/{SWARM}/*/weight/*/*")
        ack = answer(f2, KEYS.update("f2"), b"ack")

        def weight(value: float) -> bytes:
            return serialize(message_class(kind.name)(data=value), kind.name)

        until("the tool's weight reaches the leader",
              lambda: _put_and_check(tool, weights, weight(2.0), key))
        f2.put(key, weight(100.0))
        flushed(leader, "f2")
        tool.put(key, weight(3.0))
        assert set(weights.wait_for(weight(3.0))) == {weight(2.0)}
        ack.undeclare()
    finally:
        sessions.close_all()


def _put_and_check(leader: zenoh.Session, inbox: Inbox, payload: bytes,
                   key: str = KEYS.control) -> bool:
    """Put ``payload`` on ``key``; whether it came within a second (a subscription takes
    a moment to reach the router)."""
    leader.put(key, payload)
    return inbox.received(payload, 1.0)


def test_a_follower_cannot_answer_for_another_nor_poll_it(
        sessions: Sessions, router: zenoh.Session) -> None:
    leader, f1, f2 = (sessions.open(n) for n in ("leader", "f1", "f2"))
    answers = [answer(f1, KEYS.update("f1"), b"f1"),
               answer(f2, KEYS.update("f1"), b"f2 posing as f1"),
               answer(f2, KEYS.update("f2"), b"ack")]
    # f2's declarations go out before its reply (same link, at a higher priority).
    flushed(leader, "f2")
    until("f1 answers", lambda: b"f1" in replies(leader, KEYS.update("f1")))
    assert replies(leader, KEYS.update("f1")) == [b"f1"]
    # f2 polling f1 hears only its own fake (a session's own traffic is never filtered).
    # The get's own timeout bounds this wait: had it passed, f1's answer would be back in
    # about a millisecond.
    assert replies(f2, KEYS.update("f1"), timeout=1.0) == [b"f2 posing as f1"]
    for queryable in answers:
        queryable.undeclare()


def test_a_follower_cannot_read_another_followers_frames(
        sessions: Sessions, router: zenoh.Session) -> None:
    leader, f2 = sessions.open("leader"), sessions.open("f2")
    frames = Inbox(f2, KEYS.fresh("f1"))
    control = Inbox(f2, KEYS.control)  # declared after frames' subscriber, same link
    fresh = leader.declare_publisher(KEYS.fresh("f1"))
    until("f2's control subscription reaches the leader",
          lambda: _put_and_check(leader, control, b"hello"))
    # The leader never even learns of f2's subscriber, so a LeaderNode never sends f1's
    # frames (it puts fresh only while a subscriber matches)...
    assert not cast(zenoh.MatchingStatus, fresh.matching_status).matching  # stubs: bool
    # ...and a put anyway is not passed on: the control put after it (same link to f2,
    # same priority) comes alone.
    fresh.put(b"f1's frame")
    leader.put(KEYS.control, b"marker")
    control.wait_for(b"marker")
    assert frames.payloads == []


def test_an_observer_reads_stats_but_puts_nothing(sessions: Sessions,
                                                  router: zenoh.Session) -> None:
    leader, f1, o1, o2 = (sessions.open(n) for n in ("leader", "f1", "o1", "o2"))
    stats = [Inbox(o, KEYS.all_stats) for o in (o1, o2)]
    control = Inbox(f1, KEYS.control)
    until("the observers' subscriptions reach the leader",
          lambda: _put_stats(leader, stats, b"stats 0"))
    until("f1's subscription reaches the leader",
          lambda: _put_and_check(leader, control, b"hello"))
    for key in (KEYS.control, KEYS.stats("f1"), KEYS.leader_stats):
        o1.put(key, b"rogue")
    # A bounded wait: o1 may send nothing that would follow its puts through the router
    # as a barrier (its declarations travel at Zenoh's control priority, ahead of any
    # put). Had the router passed them on, they would arrive within a millisecond here.
    time.sleep(0.5)
    leader.put(KEYS.control, b"marker")
    leader.put(KEYS.stats("f1"), b"marker")
    assert set(control.wait_for(b"marker")) == {b"hello"}
    assert set(stats[1].wait_for(b"marker")) == {b"stats 0"}
    # A session's own traffic is never filtered: o1 hears its own put.
    assert b"rogue" in stats[0].wait_for(b"marker")


def _put_stats(leader: zenoh.Session, inboxes: list[Inbox], payload: bytes) -> bool:
    """Put ``payload`` on f1's stats; whether every inbox got it within a second."""
    leader.put(KEYS.stats("f1"), payload)
    return all(inbox.received(payload, 1.0) for inbox in inboxes)
