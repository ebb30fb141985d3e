"""The newest-only baseline in the simulator: a camera's slot of one keeps the newest
frame, and newest-only TCP through a small send buffer keeps AoI bounded where
fixed-rate TCP past capacity queues up."""

from __future__ import annotations

import json

import pytest

from wiswarm_zenoh.cli.main import main
from wiswarm_zenoh.sim.link import LinkParams, LinkScenario, link_curve, run_link
from wiswarm_zenoh.sim.scenario import PAPER_FRAME_BYTES, WifiScenario, run_wifi
from wiswarm_zenoh.sim.source import PeriodicNewest


def test_the_slot_gives_the_newest_frame_not_yet_pulled() -> None:
    slot = PeriodicNewest(rate=10.0, phase=0.05)
    assert slot.pull(0.0) is None
    assert slot.pull(0.05) == pytest.approx(0.05)
    assert slot.pull(0.1) is None  # frame 0 was taken; frame 1 comes at 0.15
    assert slot.pull(1.0) == pytest.approx(0.95)  # frames 1..8 were replaced unsent
    assert slot.dropped == 8
    assert len(slot) == 0
    assert slot.next_frame_time(1.0) == pytest.approx(1.05)


def test_a_waiting_frame_is_replaced_by_a_newer_one_and_counted() -> None:
    slot = PeriodicNewest(rate=1.0, phase=0.0)
    assert len(slot) == 0
    slot.pull(0.0)
    assert slot.pull(0.5) is None
    assert slot.generated(2.0) == 3
    assert slot.pull(2.0) == 2.0  # 1.0 was waiting, 2.0 replaced it
    assert slot.dropped == 1


def _mean(system: str, duration: float, **kwargs: object) -> float:
    scenario = WifiScenario(n=8, system=system, duration=duration, seed=2,
                            **kwargs)  # type: ignore[arg-type]
    return run_wifi(scenario).mean("mean_aoi_s")


def test_newest_stays_fresh_where_fixed_rate_tcp_past_capacity_queues_up() -> None:
    short, long = _mean("newest", 10.0), _mean("newest", 20.0)
    assert long < 1.3 * short  # no backlog builds: nothing waits but the newest frame
    assert _mean("tcp", 10.0, rate=50.0) > 10 * short


def test_a_send_buffer_of_many_frames_is_staler_than_a_small_one() -> None:
    small = _mean("newest", 10.0)
    big = _mean("newest", 10.0, send_buffer=4 * PAPER_FRAME_BYTES)
    assert big > 1.5 * small


def test_newest_has_no_push_rate_and_runs_over_the_link_with_tcp_small_queues() -> None:
    result = run_link(LinkScenario(n=4, system="newest", duration=5.0, seed=1))
    assert result.rate is None
    assert result.channel["uplink_drops"] == 0  # TSQ keeps TCP's backlog in the host
    assert all(f.deliveries > 0 for f in result.followers)
    curve = link_curve([4], [("newest", None)], LinkParams(), PAPER_FRAME_BYTES, 5.0, seed=1)
    assert curve == [result]
    with pytest.raises(ValueError, match="newest takes no push rate"):
        link_curve([4], [("newest", 5.0)], LinkParams(), PAPER_FRAME_BYTES, 5.0, seed=1)


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"fifo_frames": 3}, "fifo_frames"), ({"send_buffer": 0}, "send_buffer")])
def test_bad_newest_workloads_name_the_field(kwargs: dict[str, int], field: str) -> None:
    with pytest.raises(ValueError, match=field):
        WifiScenario(n=2, system="newest", **kwargs)  # type: ignore[arg-type]


def test_the_cli_runs_newest_and_refuses_a_rate(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "wifi", "--n", "2", "--system", "newest", "--send-buffer", "8192",
                 "--duration", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["system"] == "newest" and out["rate"] is None
    for flags, error in ((["--system", "newest", "--rate", "5"], "--rate is the push rate"),
                         (["--system", "tcp", "--send-buffer", "8192"], "--send-buffer is")):
        assert main(["sim", "wifi", "--n", "2", *flags]) == 2
        assert error in capsys.readouterr().err
