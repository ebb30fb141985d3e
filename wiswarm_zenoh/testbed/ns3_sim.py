"""The ns-3 scenario as a plain simulation (no taps, any speed): the paper's workloads at
MAC level, their AoI measured at the access point, for checking ``sim``'s 802.11 model
against ns-3 (``benchmarks/bench_wifi_model.py``)."""

from __future__ import annotations

import json
import subprocess
from dataclasses import dataclass

from wiswarm_zenoh.testbed.ns3_build import scenario_binary

WARMUP_S = 1.0  # the stations associate, then the cameras start; the window opens here


@dataclass(frozen=True)
class Ns3Run:
    """One simulated run: N stations, push (at ``rate`` frames/s; ``blocking``: through
    a blocking socket into a MAC queue of ``queue_packets``, else thrown at the queue,
    which drops what does not fit, as through a tap) or wiswarm (round-robin polls,
    cameras at 100 fps)."""

    n: int
    system: str
    rate: float = 50.0
    frame_bytes: int = 50176
    window_s: float = 30.0
    standard: str = "80211n"
    data_mode: str | None = None
    ampdu: bool = False
    queue_packets: int = 128
    blocking: bool = True
    seed: int = 1


@dataclass(frozen=True)
class Ns3Result:
    mean_aoi_s: float  # over the stations
    frames_per_s: float  # delivered, per station
    loss: float  # push: share of offered frames not delivered whole; wiswarm: 0
    failed_tx_share: float


def run_ns3(run: Ns3Run) -> Ns3Result:
    """Simulate ``run`` with the ns-3 scenario (built on first use)."""
    argv = [str(scenario_binary()), "--taps=0", f"--stations={run.n}",
            f"--standard={run.standard}", f"--system={run.system}",
            f"--pushRate={run.rate:g}", f"--frameBytes={run.frame_bytes}",
            f"--warmup={WARMUP_S}", f"--duration={WARMUP_S + run.window_s:g}",
            f"--ampdu={int(run.ampdu)}", f"--queuePackets={run.queue_packets}",
            f"--blocking={int(run.blocking)}", f"--seed={run.seed}", "--statsPeriod=1e9"]
    if run.data_mode:
        argv.append(f"--dataMode={run.data_mode}")
    done = subprocess.run(argv, capture_output=True, text=True, check=True)
    lines = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    aoi = next(line for line in lines if line["event"] == "aoi")
    end = next(line for line in lines if line["event"] == "end")
    stations = aoi["stations"]
    fps = sum(s["frames"] for s in stations) / len(stations) / aoi["window_s"]
    acked = sum(node["acked"] for node in end["nodes"])
    failed = sum(node["nacked"] for node in end["nodes"])
    return Ns3Result(
        mean_aoi_s=sum(s["mean_aoi_s"] for s in stations) / len(stations),
        frames_per_s=fps,
        loss=max(0.0, 1 - fps / run.rate) if run.system == "push" else 0.0,
        failed_tx_share=failed / (acked + failed) if acked + failed else 0.0,
    )
