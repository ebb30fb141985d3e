"""The ``link`` channel, the testbed's tc-tbf-shaped veth: each direction carries exactly
its rate after one burst, tail-drops past ``rate * latency + burst``, WiSwarm sits on the
round-robin floor, and fixed-rate push baselines drown (UDP loses whole frames, TCP's
FIFO grows)."""

from __future__ import annotations

import json

import pytest

from wiswarm_zenoh.cli import main as cli
from wiswarm_zenoh.sim.engine import Engine
from wiswarm_zenoh.sim.link import (
    TCP_SMALL_QUEUE_PACKETS,
    LinkAirtime,
    LinkMedium,
    LinkParams,
    LinkScenario,
    ZenohAirtime,
    link_curve,
    poll_cycle,
    round_robin_floor,
    run_link,
)
from wiswarm_zenoh.sim.medium import Mpdu, Station
from wiswarm_zenoh.sim.metrics import WifiResult
from wiswarm_zenoh.sim.scenario import DEFAULT_HOST_DELAY, PAPER_FRAME_BYTES

FULL = 1514.0  # a full-size packet as tbf counts it: 1500 B of IP and the Ethernet header
REPLY = PAPER_FRAME_BYTES + 135  # a reply carrying a whole frame: the core's header
# ... over Zenoh's TCP link: 35 segments, each with 52 B of TCP/IP and 14 B of Ethernet.
REPLY_WIRE = REPLY + 35 * (52 + 14)
MODULE = "wiswarm_zenoh.cli.sim"


@pytest.fixture(autouse=True)
def _registered(monkeypatch: pytest.MonkeyPatch) -> None:
    if MODULE not in cli.SUBCOMMAND_MODULES:
        monkeypatch.setattr(cli, "SUBCOMMAND_MODULES", (*cli.SUBCOMMAND_MODULES, MODULE))


def _run(**kwargs: object) -> WifiResult:
    return run_link(LinkScenario(**kwargs))  # type: ignore[arg-type]


def test_packets_are_cut_and_counted_as_ethernet_ipv4_and_tbf_count_them() -> None:
    air = LinkAirtime(LinkParams())
    fragments = air.udp_packets(PAPER_FRAME_BYTES)
    assert len(fragments) == 34 and fragments[:-1] == [1500] * 33  # 1480 B of data each
    assert sum(fragments) == PAPER_FRAME_BYTES + 8 + 34 * 20
    assert air.tcp_mss == 1448
    assert air.unicast_busy(1500) == air.broadcast_busy(1500) == FULL
    segments = ZenohAirtime(LinkParams()).udp_packets(REPLY)
    assert segments == [1500] * 34 + [REPLY - 34 * 1448 + 52]


def _saturate(medium: LinkMedium, station: Station, sent: list[float]) -> None:
    """Keep 100 full-size packets queued at ``station``; ``sent`` gets departure times."""

    def again(data: object, ok: bool, now: float) -> None:
        sent.append(now)
        medium.send(station, Mpdu(FULL, 1.0, True, again, None))

    for _ in range(100):
        medium.send(station, Mpdu(FULL, 1.0, True, again, None))


@pytest.mark.parametrize("downlink", [False, True])
def test_a_saturated_direction_carries_its_rate_after_one_burst(downlink: bool) -> None:
    link = LinkParams(rate_bps=20_000_000, down_rate_bps=5_000_000)
    engine = Engine(0)
    medium = LinkMedium(engine, link)
    sent: list[float] = []
    _saturate(medium, medium.station("s", downlink=downlink), sent)
    duration = 10.0
    engine.run(duration)
    rate = (link.down_bps if downlink else link.rate_bps) / 8
    at_once = int(link.burst_bytes // FULL)  # what a full bucket lets out at once
    assert sent[:at_once] == [0.0] * at_once and sent[at_once] > 0
    assert len(sent) * FULL == pytest.approx(link.burst_bytes + rate * duration, abs=FULL)
    counters = medium.counters()
    direction = "downlink" if downlink else "uplink"
    assert counters[f"{direction}_utilisation"] == pytest.approx(
        1.0 + link.burst_bytes / (rate * duration), abs=FULL / (rate * duration))
    assert counters[f"{direction}_drops"] == 0


def test_tail_drop_once_the_backlog_would_pass_rate_times_latency_plus_burst() -> None:
    link = LinkParams(queue_s=0.05)
    limit = link.limit_bytes(link.rate_bps)
    assert limit == 20_000_000 / 8 * 0.05 + 32 * 1024  # tc's own arithmetic
    engine = Engine(0)
    medium = LinkMedium(engine, link)
    station = medium.station("s")
    left: list[float] = []
    accepted = [medium.send(station, Mpdu(FULL, 1.0, True, lambda d, ok, now: left.append(now),
                                          None)) for _ in range(400)]
    at_once, queued = int(link.burst_bytes // FULL), int(limit // FULL)
    assert accepted == [True] * (at_once + queued) + [False] * (400 - at_once - queued)
    assert medium.uplink.drops == 400 - at_once - queued
    engine.run(1.0)
    assert len(left) == at_once + queued  # what got in all leaves: a FIFO loses nothing more
    assert max(left) == pytest.approx(((at_once + queued) * FULL - link.burst_bytes) / 2.5e6)


def test_the_poll_cycle_is_the_reply_at_the_link_rate_while_the_bucket_hides_the_idle() -> None:
    link = LinkParams()
    s, reply = poll_cycle(PAPER_FRAME_BYTES, link, DEFAULT_HOST_DELAY)
    assert s == pytest.approx(REPLY_WIRE * 8 / 20e6)
    assert reply == pytest.approx(s - DEFAULT_HOST_DELAY)  # the poll goes on the tokens
    # A turnaround longer than the bucket can hide: the cycle is the chain of the two.
    s, reply = poll_cycle(PAPER_FRAME_BYTES, link, 0.02)
    assert reply == pytest.approx((REPLY_WIRE - link.burst_bytes) * 8 / 20e6)
    assert s == pytest.approx(0.02 + reply)


@pytest.mark.parametrize("n", [8, 14])
def test_wiswarm_sits_on_the_round_robin_floor(n: int) -> None:
    result = _run(n=n, system="wiswarm", duration=20.0, seed=1)
    link = LinkParams()
    floor = round_robin_floor(n, PAPER_FRAME_BYTES, link, DEFAULT_HOST_DELAY, sample_rate=100.0)
    assert result.mean("mean_aoi_s") == pytest.approx(floor, rel=0.01)
    # S (N/2 + 1) alone leaves out the camera's half period and the turnaround: still 5 %.
    s, _ = poll_cycle(PAPER_FRAME_BYTES, link, DEFAULT_HOST_DELAY)
    assert result.mean("mean_aoi_s") == pytest.approx(s * (n / 2 + 1), rel=0.05)
    # The first polls ride the token bucket's burst and are quicker than the link's steady
    # rate: at most one poll per follower outlasts the timeout they gave, and teaches it.
    assert result.channel["timeouts"] <= n and result.channel["uplink_drops"] == 0
    assert result.channel["uplink_utilisation"] == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize(
    ("link", "host_delay"),
    [
        (LinkParams(), 0.02),  # a turnaround longer than the bucket can hide
        (LinkParams(down_rate_bps=80_000, burst_bytes=1514), DEFAULT_HOST_DELAY),  # polls slow
    ],
)
def test_wiswarm_sits_on_the_floor_where_the_reply_does_not_set_the_pace(
    link: LinkParams, host_delay: float
) -> None:
    # Control with every poll, as the paper sends it: the polls' bytes set the pace.
    result = _run(n=4, system="wiswarm", duration=30.0, seed=1, host_delay=host_delay, link=link,
                  control_period=0.0)
    floor = round_robin_floor(4, PAPER_FRAME_BYTES, link, host_delay, sample_rate=100.0,
                              control_period=0.0)
    assert result.mean("mean_aoi_s") == pytest.approx(floor, rel=0.02)
    s, _ = poll_cycle(PAPER_FRAME_BYTES, link, host_delay, control_period=0.0)
    assert result.duration / result.channel["polls"] == pytest.approx(s, rel=0.01)
    assert result.channel["uplink_utilisation"] < 0.95


def test_udp_at_50_fps_fills_the_queue_and_loses_almost_every_frame() -> None:
    # 8 x 50 fps of 51 kB is 8 times the link: the FIFO stays full, and a frame needs 34
    # fragments of room at once where the link frees 6 kB between two frames' arrivals.
    short = _run(n=8, system="udp", rate=50.0, duration=10.0, seed=2)
    long = _run(n=8, system="udp", rate=50.0, duration=20.0, seed=2)
    wiswarm = _run(n=8, system="wiswarm", duration=10.0, seed=2)
    assert short.channel["uplink_drops"] > 0
    assert short.channel["uplink_utilisation"] == pytest.approx(1.0, abs=0.01)
    limit = LinkParams().limit_bytes(20_000_000)
    assert short.channel["uplink_backlog_kb"] * 1e3 > 0.9 * limit
    assert sum(f.deliveries for f in short.followers) <= 8 * 2  # a few before the FIFO filled
    assert short.mean("mean_aoi_s") > 30 * wiswarm.mean("mean_aoi_s")
    assert long.mean("mean_aoi_s") > 1.8 * short.mean("mean_aoi_s")  # nothing new arrives


def test_tcp_at_50_fps_shares_the_link_fairly_while_its_fifo_grows() -> None:
    n = 8
    short = _run(n=n, system="tcp", rate=50.0, duration=10.0, seed=3)
    long = _run(n=n, system="tcp", rate=50.0, duration=20.0, seed=3)
    assert short.channel["uplink_drops"] == 0  # TCP Small Queues keep it below the limit
    assert short.channel["uplink_backlog_kb"] * 1e3 <= n * TCP_SMALL_QUEUE_PACKETS * FULL
    frame_wire = PAPER_FRAME_BYTES + 35 * (52 + 14)
    fair_fps = 20e6 / 8 / frame_wire / n
    for f in long.followers:
        assert f.throughput_fps == pytest.approx(fair_fps, rel=0.05)
    assert long.mean("mean_aoi_s") > 1.8 * short.mean("mean_aoi_s")  # the FIFO grows


def test_below_capacity_both_baselines_deliver_every_frame_fresh() -> None:
    for system in ("udp", "tcp"):
        result = _run(n=8, system=system, rate=3.0, duration=10.0, seed=4)
        assert result.channel["uplink_drops"] == 0
        assert all(f.deliveries >= 29 for f in result.followers)
        assert result.mean("mean_aoi_s") < 0.2  # half the frame period and a transfer


def test_the_same_seed_gives_the_same_run() -> None:
    for system in ("wiswarm", "udp", "tcp"):
        runs = [_run(n=3, system=system, rate=30.0, duration=2.0, seed=5).as_dict()
                for _ in range(2)]
        assert runs[0] == runs[1]
    assert _run(n=3, system="udp", rate=5.0, duration=2.0, seed=5).followers != _run(
        n=3, system="udp", rate=5.0, duration=2.0, seed=6).followers


def test_link_curve_runs_every_n_and_system_in_order() -> None:
    link = LinkParams(rate_bps=10_000_000)
    systems: list[tuple[str, float | None]] = [("wiswarm", None), ("tcp", 5.0)]
    runs = link_curve([2, 4], systems, link, PAPER_FRAME_BYTES, 2.0, seed=7)
    assert [(r.n, r.system, r.rate) for r in runs] == [
        (2, "wiswarm", None), (2, "tcp", 5.0), (4, "wiswarm", None), (4, "tcp", 5.0)]
    assert runs[3] == run_link(LinkScenario(n=4, system="tcp", rate=5.0, duration=2.0,
                                            seed=7, link=link))
    with pytest.raises(ValueError, match="rate"):
        link_curve([2], [("udp", None)], link, PAPER_FRAME_BYTES, 2.0, seed=7)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"rate_bps": 0}, "rate_bps"),
        ({"down_rate_bps": 10**12}, "down_rate_bps"),
        ({"queue_s": 0.0}, "queue_s"),
        ({"queue_s": float("nan")}, "queue_s"),
        ({"burst_bytes": 1000}, "burst_bytes"),
        ({"mtu": 100}, "mtu"),
    ],
)
def test_impossible_links_are_refused(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ValueError, match=field):
        LinkParams(**kwargs)  # type: ignore[arg-type]


def test_cli_prints_the_table_and_the_json_parses(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["sim", "link", "--n", "3", "--system", "udp", "--rate", "5", "--duration", "2",
            "--link-rate", "10mbit", "--down-rate", "1mbit", "--queue", "100ms"]
    assert cli.main(argv) == 0
    text = capsys.readouterr().out
    assert text.startswith("udp N=3 over 2 s:") and "uplink_drops 0" in text
    assert cli.main([*argv, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["system"] == "udp" and len(out["followers"]) == 3
    assert out["channel"]["uplink_utilisation"] > 0


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--link-rate", "0"], "--link-rate"),
        (["--down-rate", "fast"], "--down-rate"),
        (["--queue", "0ms"], "--queue"),
        (["--rate", "10"], "--rate"),
        (["--system", "quic"], "system"),
    ],
)
def test_cli_bad_values_end_with_one_line_and_exit_2(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli.main(["sim", "link", "--n", "3", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err
    assert err.count("\n") == 1
