"""The dashboard's state without a network: what a new browser is given, what it is sent
after, and what is forgotten."""

from __future__ import annotations

from wiswarm_zenoh.dashboard.state import (
    KEPT_S,
    LEADER_SILENCE_S,
    MAX_FOLLOWERS,
    Message,
    SwarmState,
)


class Outbox:
    """Numbers the messages as the hub does, and keeps them."""

    def __init__(self) -> None:
        self.sent: list[Message] = []

    def __call__(self, message: Message) -> int:
        self.sent.append(message)
        return len(self.sent)


class Clock:
    def __init__(self, now: float = 1000.0) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now


def test_a_snapshot_holds_the_last_window_and_where_each_sawtooth_enters_it() -> None:
    outbox = Outbox()
    state = SwarmState("s", outbox)
    state.add_deliveries([("f1", 10.0, 10.1), ("f1", None, 11.0), ("f2", 12.0, 12.5)])
    state.add_deliveries([("f1", 50.0, 50.2)])  # 40 s later: the first ones are forgotten
    snapshot, since = state.snapshot()
    assert since == len(outbox.sent) == 2
    assert snapshot["traces"] == {"f1": {"tau": 10.0, "records": [(50.0, 50.2)]},
                                  "f2": {"tau": 12.0, "records": []}}
    assert outbox.sent[0] == {"type": "deliveries", "records": [
        ("f1", 10.0, 10.1), ("f1", None, 11.0), ("f2", 12.0, 12.5)]}
    assert 50.2 - KEPT_S > 12.5


def test_the_freshest_update_forgotten_is_where_the_sawtooth_starts() -> None:
    state = SwarmState("s", Outbox())
    # An old update delivered after a fresher one does not take the age back up.
    state.add_deliveries([("f1", 5.0, 5.1), ("f1", 4.0, 5.2), ("f1", None, 6.0)])
    state.add_deliveries([("f1", 100.0, 100.1)])
    assert state.snapshot()[0]["traces"]["f1"]["tau"] == 5.0


def test_followers_past_the_limit_are_refused() -> None:
    state = SwarmState("s", Outbox())
    assert state.add_deliveries([(f"f{i}", 1.0, 2.0) for i in range(MAX_FOLLOWERS + 3)]) == 3
    assert len(state.snapshot()[0]["traces"]) == MAX_FOLLOWERS


def test_polls_per_second_come_from_the_counter_and_restart_with_a_new_leader() -> None:
    clock, outbox = Clock(), Outbox()
    state = SwarmState("s", outbox, clock)
    rates = []
    for dt, polls in ((0.0, 100), (0.4, 140), (1.0, 300), (2.0, 500), (2.5, 10), (3.5, 60)):
        clock.now = 1000.0 + dt
        state.set_stats({"follower": "f1", "polls": polls})
        rates.append(outbox.sent[-1]["record"]["polls_per_s"])
    assert rates == [None, None, 200.0, 200.0, None, 50.0]


def test_no_leader_after_two_seconds_of_silence_and_since_when() -> None:
    clock, outbox = Clock(), Outbox()
    state = SwarmState("s", outbox, clock)
    state.status()
    assert outbox.sent[-1] == {"type": "status", "now": 1000.0, "started_at": 1000.0,
                               "leader_seen_at": None, "leader_alive": False, "bad_input": 0}
    clock.now = 1001.0
    state.set_leader({"leader": "a", "epoch": 1, "followers": []})
    clock.now += LEADER_SILENCE_S
    state.status()
    assert outbox.sent[-1]["leader_alive"]
    clock.now += 0.01
    state.bad_input.report("wiswarm/s/f1/stats", "not JSON")
    state.status()
    assert outbox.sent[-1] == {"type": "status", "now": clock.now, "started_at": 1000.0,
                               "leader_seen_at": 1001.0, "leader_alive": False,
                               "bad_input": 1}


def test_tracking_and_runs_are_kept_latest_first() -> None:
    state = SwarmState("s", Outbox())
    state.set_tracking({"uav": "u1", "x": 1.0})
    state.set_tracking({"uav": "u1", "x": 2.0})
    for run in ("a", "b", "a"):
        state.set_run({"run": run, "points": []})
    snapshot = state.snapshot()[0]
    assert snapshot["tracking"] == [{"uav": "u1", "x": 2.0}]
    assert [r["run"] for r in snapshot["runs"]] == ["b", "a"]
