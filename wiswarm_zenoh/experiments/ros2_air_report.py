"""The ROS 2 air benchmark's report: the round-robin floor, the table of the cases,
the issue's targets, what (c)'s polls and replies need of the channel, and the figure.

The floor is the stationary study's: S (N/2 + 1), S measured in (c) as the window over
the frames the ground received. What (c) needs of the channel is counted from the
leader's own record: each reply's bytes (the CDR message and its framing) cut into TCP
segments with their headers going up, each poll in a packet going down with the
acknowledgements of the replies' segments (one per two, as Linux's delayed ACKs)."""

from __future__ import annotations

import math
from pathlib import Path

from wiswarm_zenoh.experiments.report_cells import ms, ratio, times
from wiswarm_zenoh.experiments.ros2_air import CASES, KINDS, SEARCHED, AirResults, CaseResult
from wiswarm_zenoh.experiments.sweep_report import SEARCH_HEAD, SEARCH_NAMES, search_cells
from wiswarm_zenoh.experiments.testbed_study_report import MEDIUM_COLUMNS
from wiswarm_zenoh.testbed.spec import MAX_FRAME_BYTES, MTU

SEGMENT_BYTES = MTU - 20 - 32  # TCP payload of a full packet: IPv4, TCP with timestamps
HEADER_BYTES = MAX_FRAME_BYTES - SEGMENT_BYTES  # Ethernet, IPv4, TCP on each packet
REPLY_FRAMING = 128  # Zenoh's reply and WiSwarm's reply header around the CDR bytes
POLL_BYTES = 128  # a poll: Zenoh's query and WiSwarm's poll
TARGET_FLOOR = 1.2  # (c) within this of the floor (tbf)
TARGET_DIRECT = 20.0  # (a) / (c) at N = 8
TARGET_THROTTLED = 1.5  # (b) / (c) at N = 8
TARGET_BYTES = 0.10  # (c)'s bytes within this of what its polls and replies need


def on_wire(payload: int) -> int:
    """Bytes a TCP stream's ``payload`` takes on the link, in full-size segments."""
    return payload + math.ceil(payload / SEGMENT_BYTES) * HEADER_BYTES


def needed_bytes(run: CaseResult) -> tuple[float, float]:
    """What (c)'s polls and replies need of the channel, up and down (bytes)."""
    up = down = 0.0
    if run.replies:
        mean_reply = run.reply_bytes / run.replies + REPLY_FRAMING
        up = run.replies * on_wire(round(mean_reply))
        down = run.replies * math.ceil(math.ceil(mean_reply / SEGMENT_BYTES) / 2) * HEADER_BYTES
    empty = max(0.0, run.polls - run.replies)
    return up + empty * on_wire(REPLY_FRAMING), down + run.polls * on_wire(POLL_BYTES)


def floor_s(run: CaseResult) -> float:
    """S (N/2 + 1), S the window over the frames received in (c); NaN without frames."""
    return run.duration / run.frames * (run.case.n / 2 + 1) if run.frames else math.nan





def _mb(value: float) -> str:
    return f"{value / 1e6:.1f}"


Row = tuple[str, int, dict[str, CaseResult]]


def rows(results: AirResults) -> list[Row]:
    """(medium, N, each case's run: (b)'s at its best rate) in the order measured."""
    keys = list(dict.fromkeys((r.medium, r.case.n) for r in results.runs))
    out = []
    for medium, n in keys:
        best = results.best.get((medium, n))
        runs = {kind: results.find(medium, n, kind, best if kind == SEARCHED else None)
                for kind in CASES}
        out.append((medium, n, {kind: run for kind, run in runs.items() if run is not None}))
    return out


def case_name(run: CaseResult, results: AirResults) -> str:
    title = KINDS[run.case.kind].title
    if run.case.max_hz is None:
        return title
    best = results.best.get((run.medium, run.case.n)) == run.case.max_hz
    return f"{title} {run.case.max_hz:.3g} Hz{' (best)' if best else ''}"


def table(results: AirResults) -> list[str]:
    """One row a run: age at the ground, frames, the channel's bytes; (c)'s floor."""
    lines = ["| medium | N | case | mean AoI (ms) | p95 AoI (ms) | frames/s per robot | "
             "channel up / down (MB) | / (c) |", "|---|---|---|---|---|---|---|---|"]
    for medium, n, runs in rows(results):
        c = runs["wiswarm"].mean() if "wiswarm" in runs else math.nan
        for run in (r for r in results.runs if (r.medium, r.case.n) == (medium, n)):
            lines.append(f"| {medium} | {n} | {case_name(run, results)} | {ms(run.mean())} | "
                         f"{ms(run.mean('p95_aoi_s'))} | {run.mean('throughput_fps'):.1f} | "
                         f"{_mb(run.up_bytes)} / {_mb(run.down_bytes)} | "
                         f"{times(ratio(run.mean(), c))} |")
    return lines


def medium_lines(results: AirResults) -> list[str]:
    """Per run, the host's load and the WiFi medium's counters: what the air did."""
    head = " | ".join(title for _, title, _, _ in MEDIUM_COLUMNS)
    lines = [f"| medium | N | case | load average | {head} |",
             "|---|---|---|---|" + "---|" * len(MEDIUM_COLUMNS)]
    for run in results.runs:
        cells = " | ".join("-" if key not in run.medium_counters
                           else format(run.medium_counters[key] * scale, spec)
                           for key, _, scale, spec in MEDIUM_COLUMNS)
        lines.append(f"| {run.medium} | {run.case.n} | {case_name(run, results)} | "
                     f"{run.load:.1f} | {cells} |")
    return lines


def floor_lines(results: AirResults) -> list[str]:
    """(c) against the round-robin floor, and its bytes against what it needs."""
    lines = ["| medium | N | S measured (ms) | floor (ms) | (c) mean AoI (ms) | / floor | "
             "(c) up / down (MB) | polls and replies need (MB) | measured / need |",
             "|---|---|---|---|---|---|---|---|---|"]
    for medium, n, runs in rows(results):
        if (c := runs.get("wiswarm")) is None:
            continue
        floor = floor_s(c)
        up, down = needed_bytes(c)
        s = floor / (n / 2 + 1) * 1e3
        lines.append(f"| {medium} | {n} | {s:.1f} | {ms(floor)} | {ms(c.mean())} | "
                     f"{times(ratio(c.mean(), floor))} | {_mb(c.up_bytes)} / {_mb(c.down_bytes)}"
                     f" | {_mb(up)} / {_mb(down)} | "
                     f"{times(ratio(c.up_bytes + c.down_bytes, up + down))} |")
    return lines


def targets(results: AirResults) -> list[str]:
    """Each of the issue's targets, met or missed, with its numbers."""
    lines = []
    for medium, n, runs in rows(results):
        c, direct, throttled = runs.get("wiswarm"), runs.get("direct"), runs.get(SEARCHED)
        if c is None:
            continue
        mean = c.mean()
        checks = []
        if medium == "tbf":
            over = ratio(mean, floor_s(c))
            checks.append((f"(c) {times(over)} x the floor", over <= TARGET_FLOOR,
                           f"<= {TARGET_FLOOR}"))
        if n >= 8 and direct is not None:
            gain = ratio(direct.mean(), mean)
            checks.append((f"(a)/(c) {gain:.1f}", gain >= TARGET_DIRECT, f">= {TARGET_DIRECT:g}"))
        if n >= 8 and throttled is not None:
            gain = ratio(throttled.mean(), mean)
            checks.append((f"(b)/(c) {gain:.2f}", gain >= TARGET_THROTTLED,
                           f">= {TARGET_THROTTLED}"))
        up, down = needed_bytes(c)
        off = abs(ratio(c.up_bytes + c.down_bytes, up + down) - 1)
        checks.append((f"(c)'s bytes {off * 100:.0f} % off what polls and replies need",
                       off <= TARGET_BYTES, f"<= {TARGET_BYTES * 100:.0f} %"))
        for text, met, target in checks:
            lines.append(f"- {medium}, N = {n}: {text} (target {target}): "
                         f"{'met' if met else 'MISSED'}")
    return lines


def search_lines(results: AirResults) -> list[str]:
    """(b)'s search at each medium and N: the throttles it ran in order, its choice."""
    lines = [f"| medium | N | {SEARCH_HEAD}", "|---|---|---|---|---|"]
    for (medium, n), share in results.share.items():
        lines.append(f"| {medium} | {n} | " + search_cells(
            share, results.tried(medium, n), results.best.get((medium, n))))
    return lines


CASE_COLOURS = {"direct": "C3", "throttled": "C1", "wiswarm": "C0", "newest": "C2"}


def plot(path: Path, results: AirResults) -> None:
    """Per medium: mean AoI of every case against N with (c)'s floor (top, log
    scale), and the channel's bytes per second to the ground (bottom)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    media = list(dict.fromkeys(r.medium for r in results.runs))
    fig, axes = plt.subplots(2, len(media), figsize=(5.5 * len(media), 7), squeeze=False)
    for column, medium in enumerate(media):
        aoi, air = axes[0][column], axes[1][column]
        measured = [row for row in rows(results) if row[0] == medium]
        width = 0.8 / len(CASES)
        for x, (_, _, runs) in enumerate(measured):
            for i, kind in enumerate(CASES):
                if (run := runs.get(kind)) is None:
                    continue
                label = (f"{KINDS[kind].title}{' (best)' if kind == SEARCHED else ''}"
                         if x == 0 else None)
                at = x + (i - (len(CASES) - 1) / 2) * width
                aoi.bar(at, run.mean() * 1e3, width * 0.92, color=CASE_COLOURS[kind],
                        label=label)
                air.bar(at, run.up_bytes * 8 / run.duration / 1e6, width * 0.92,
                        color=CASE_COLOURS[kind], label=label)
            c = runs.get("wiswarm")
            if c is not None:
                aoi.hlines(floor_s(c) * 1e3, x - 0.42, x + 0.42, colors="k",
                           linestyles="--", label="floor S(N/2+1)" if x == 0 else None)
                air.scatter([x + (CASES.index("wiswarm") - (len(CASES) - 1) / 2) * width],
                            [needed_bytes(c)[0] * 8 / c.duration / 1e6], s=40,
                            marker="x", color="k", zorder=3,
                            label="(c)'s polls and replies need" if x == 0 else None)
        for ax in (aoi, air):
            ax.set_xticks(range(len(measured)), [f"N = {row[1]}" for row in measured])
            ax.grid(True, axis="y", alpha=0.3)
        aoi.set_yscale("log")
        low, high = aoi.get_ylim()
        aoi.set_ylim(low, high * 6)  # room for the legend above the bars
        air.set_ylim(0, air.get_ylim()[1] * 1.3)
        aoi.set_title(f"{medium}: mean AoI at the ground")
        aoi.set_ylabel("mean AoI per robot (ms)")
        air.set_ylabel("channel to the ground (Mbit/s)")
        aoi.legend(fontsize=7)
        air.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def report(results: AirResults) -> str:
    """The markdown report: table, floor and bytes, targets."""
    return "\n".join(["## Runs", "", *table(results), "",
                      "## (b)'s throttle", "",
                      f"By {SEARCH_NAMES['fine']} from the medium's share of each robot, up "
                      "to the camera's 30 Hz; each rate run at what the throttle gives of "
                      "the camera (every k-th frame).", "", *search_lines(results), "",
                      "## (c) against the floor, and its bytes", "", *floor_lines(results), "",
                      "## Targets", "", *targets(results), "",
                      "## The host and the air", "", *medium_lines(results), ""])
