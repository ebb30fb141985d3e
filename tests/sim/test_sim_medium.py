"""The 802.11 medium: airtime of a lone sender, retry limit, queue bound, and DCF
contention against Bianchi's saturation model."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.sim.engine import Engine
from wiswarm_zenoh.sim.medium import Medium, Mpdu, Station
from wiswarm_zenoh.sim.phy import Airtime, WifiParams


def _network(stations: int, seed: int = 3) -> tuple[Engine, Medium, Airtime, list[Station]]:
    engine = Engine(seed)
    params = WifiParams()
    medium = Medium(engine, params)
    return engine, medium, Airtime(params), [medium.station(f"s{i}") for i in range(stations)]


def test_phy_numbers_of_the_documented_defaults() -> None:
    air = Airtime(WifiParams())
    assert len(air.udp_packets(50_000)) == 34  # a 50 kB frame is 34 MAC frames
    assert max(air.udp_packets(50_000)) == 1500
    assert air.ack_time() == pytest.approx(34e-6)
    # 1538 B MPDU at 65 Mbit/s: 36 us preamble + 48 symbols + 6 us extension, SIFS, ACK.
    assert air.unicast_busy(1500) == pytest.approx(36e-6 + 48 * 4e-6 + 6e-6 + 10e-6 + 34e-6)


def test_a_lone_sender_takes_difs_backoff_and_frame_time_per_packet() -> None:
    engine, medium, air, _ = _network(0)
    st = medium.station("lone", limit=5000)
    done: list[float] = []
    busy = air.unicast_busy(1500)
    count = 2000
    for _ in range(count):
        medium.send(st, Mpdu(busy, 1.0, True, lambda d, ok, now: done.append(now), None))
    engine.run(until=10.0)
    assert len(done) == count
    assert medium.collisions == 0
    params = medium.params
    per_packet = params.difs + params.cw_min / 2 * params.slot + busy
    assert done[-1] == pytest.approx(count * per_packet, rel=0.02)


def test_a_frame_that_never_gets_through_is_dropped_after_the_retry_limit() -> None:
    engine, medium, air, (st,) = _network(1)
    outcome: list[bool] = []

    def hook(data: object, ok: bool, now: float) -> None:
        outcome.append(ok)

    medium.send(st, Mpdu(air.unicast_busy(500), 0.0, True, hook, None))
    engine.run(until=1.0)
    assert outcome == [False]
    assert medium.attempts == medium.params.max_attempts


def test_a_full_mac_queue_refuses_frames() -> None:
    _, medium, air, (st,) = _network(1)
    mpdu = Mpdu(air.unicast_busy(1500), 1.0, True, lambda d, ok, now: None, None)
    accepted = [medium.send(st, mpdu) for _ in range(st.limit + 5)]
    assert accepted.count(True) == st.limit
    assert st.room() == 0


def _bianchi_collision_probability(n: int, params: WifiParams) -> float:
    """Fixed point of Bianchi's model with a retry limit: per-attempt collision prob."""
    cws = [min((params.cw_min + 1) * 2**j - 1, params.cw_max) for j in range(params.max_attempts)]

    def gap(q: float) -> float:
        attempts = sum(q**j for j in range(len(cws)))
        slots = sum(q**j * (1 + cw / 2) for j, cw in enumerate(cws))
        tau = attempts / slots
        return 1 - (1 - tau) ** (n - 1) - q

    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if gap(mid) > 0 else (lo, mid)
    return lo


@pytest.mark.parametrize("n", [5, 15])
def test_saturated_contention_matches_bianchi_and_shares_fairly(n: int) -> None:
    engine, medium, air, stations = _network(n)
    busy = air.unicast_busy(1500)
    delivered = [0] * n

    def refill(i: int) -> None:
        def hook(data: object, ok: bool, now: float) -> None:
            delivered[i] += ok
            medium.send(stations[i], Mpdu(busy, 1.0, True, hook, None))

        for _ in range(4):
            medium.send(stations[i], Mpdu(busy, 1.0, True, hook, None))

    for i in range(n):
        refill(i)
    engine.run(until=30.0)
    measured = medium.collided_attempts / medium.attempts
    expected = _bianchi_collision_probability(n, medium.params)
    assert measured == pytest.approx(expected, rel=0.1)
    jain = sum(delivered) ** 2 / (n * sum(d * d for d in delivered))
    assert jain > 0.99  # long-run fair; binary backoff is only unfair short-term
