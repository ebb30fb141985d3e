"""The demo's pictures: 2-D trajectories of UAVs and cars, AoI and tracking-error
histograms (PNG, matplotlib), and an animated GIF of the world seen from above with
each UAV's field of view (drawn with OpenCV, written with Pillow); for a comparison of
systems, their AoI and tracking error against time in one figure and their runs side by
side in one GIF."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import cv2
import matplotlib
import numpy as np
from matplotlib.patches import Rectangle
from numpy.typing import NDArray
from PIL import Image

from wiswarm_apps.tracking.demo import DemoRun
from wiswarm_apps.tracking.geometry import CameraModel, Pose
from wiswarm_apps.tracking.render import Renderer
from wiswarm_apps.tracking.report import aoi_series
from wiswarm_apps.tracking.world import World

matplotlib.use("Agg")
import matplotlib.pyplot as plt

GIF_FPS = 5.0
GIF_MAX_FRAMES = 300
GIF_RESOLUTION_M = 0.05
GIF_GREY_STEP = 8  # 32 grey levels: the noisy ground compresses to ~25 kB a frame
COLUMNS = {name: i for i, name in enumerate(
    ("t", "uav_x", "uav_y", "uav_z", "uav_yaw", "car_x", "car_y", "error_m"))}


def _samples(run: DemoRun, uav: str) -> NDArray[np.float64]:
    result = run.uavs.get(uav)
    if result is None or not result.samples:
        return np.empty((0, len(COLUMNS)), dtype=np.float64)
    return np.asarray(result.samples, dtype=np.float64)


def _colour(index: int) -> tuple[float, float, float]:
    rgba = plt.get_cmap("tab10")(index % 10)
    return (float(rgba[0]), float(rgba[1]), float(rgba[2]))


def plot_trajectories(run: DemoRun, path: Path) -> None:
    arena = run.options.world_config().arena
    fig, ax = plt.subplots(figsize=(10, 5.6))
    ax.add_patch(Rectangle((0, 0), arena.width_m, arena.height_m, fill=False, color="k"))
    for i, uav in enumerate(run.options.uav_ids):
        s = _samples(run, uav)
        if not len(s):
            continue
        c = COLUMNS
        ax.plot(s[:, c["car_x"]], s[:, c["car_y"]], "--", color=_colour(i), lw=1.0,
                label=f"car {i}")
        ax.plot(s[:, c["uav_x"]], s[:, c["uav_y"]], "-", color=_colour(i), lw=1.6,
                alpha=0.7, label=uav)
    ax.set(xlim=(-0.5, arena.width_m + 0.5), ylim=(-0.5, arena.height_m + 0.5),
           xlabel="x (m)", ylabel="y (m)", aspect="equal",
           title=f"{run.options.system}: UAVs (solid) tracking cars (dashed)")
    ax.legend(loc="upper right", fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_histograms(run: DemoRun, aoi_path: Path, error_path: Path) -> None:
    start, end = run.epoch, run.epoch + run.measured_s
    for path, what in ((aoi_path, "aoi"), (error_path, "error")):
        fig, ax = plt.subplots(figsize=(7, 4))
        for i, uav in enumerate(run.options.uav_ids):
            if what == "aoi":
                values = aoi_series(run.deliveries, uav, start, end, step=2e-4)[1] * 1e3
            else:
                values = _samples(run, uav)[:, COLUMNS["error_m"]]
            if len(values):
                ax.hist(values, bins=40, histtype="step", density=True, color=_colour(i),
                        label=uav)
        ax.set(xlabel="AoI at the leader (ms)" if what == "aoi" else "tracking error (m)",
               ylabel="share of time (density)",
               title=f"{run.options.system}: "
                     + ("AoI" if what == "aoi" else "UAV-car ground distance"))
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)


def _footprint(camera: CameraModel, pose: Pose) -> NDArray[np.float64]:
    w, h = camera.width - 0.5, camera.height - 0.5
    corners = ((-0.5, -0.5), (w, -0.5), (w, h), (-0.5, h))
    return np.asarray([camera.pixel_to_world(pose, u, v) for u, v in corners])


def _palette(uavs: int) -> Image.Image:
    """A fixed palette (grey levels, the UAV colours, white), used without dithering:
    dithering noise would double the size of every frame."""
    colours = [(g, g, g) for g in range(0, 256, GIF_GREY_STEP)] + [
        tuple(int(255 * k) for k in _colour(i)) for i in range(min(uavs, 10))
    ] + [(255, 255, 255)]
    palette = Image.new("P", (1, 1))
    palette.putpalette([channel for rgb in colours for channel in rgb])
    return palette


def write_gif(runs: Sequence[DemoRun], path: Path) -> None:
    """The arena from above during the window, real time at GIF_FPS frames a second; one
    panel per run, side by side (runs of one world: the same cars, seen at once)."""
    options = runs[0].options
    world = World(options.world_config())
    renderer = Renderer(world)
    arena, r = world.arena, GIF_RESOLUTION_M
    times = np.arange(0.0, min(run.measured_s for run in runs), 1.0 / GIF_FPS)
    times = times[:: max(1, -(-len(times) // GIF_MAX_FRAMES))]

    def to_px(xy: NDArray[np.float64]) -> NDArray[np.int32]:
        u, v = xy[..., 0] / r - 0.5, (arena.height_m - xy[..., 1]) / r - 0.5
        return np.round(np.stack([u, v], axis=-1)).astype(np.int32)

    tracks = [{uav: _samples(run, uav) for uav in options.uav_ids} for run in runs]
    palette = _palette(options.uavs)
    images = []
    for t in times:
        ground = cv2.cvtColor(renderer.overview(float(t), r), cv2.COLOR_GRAY2RGB)
        panels = []
        for run, run_tracks in zip(runs, tracks, strict=True):
            image = ground.copy()
            for i, uav in enumerate(options.uav_ids):
                s, c = run_tracks[uav], COLUMNS
                if not len(s):
                    continue
                colour = tuple(int(255 * k) for k in _colour(i))
                pose = Pose(*(float(np.interp(t, s[:, c["t"]], s[:, c[name]]))
                              for name in ("uav_x", "uav_y", "uav_z", "uav_yaw")))
                cv2.polylines(image, [to_px(_footprint(options.camera, pose))], True, colour, 2)
                cv2.circle(image, tuple(int(p) for p in to_px(np.array([pose.x, pose.y]))), 3,
                           colour, -1)
                car = np.asarray(world.car_position(i, float(t)))
                cv2.circle(image, tuple(int(p) for p in to_px(car)), 7, colour, 1)
            cv2.putText(image, f"{run.options.system} t = {t:5.1f} s", (6, 16),
                        cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1, cv2.LINE_AA)
            panels.append(image)
        gap = np.full((ground.shape[0], 4, 3), 255, dtype=np.uint8)
        joined = np.hstack([part for panel in panels for part in (gap, panel)][1:])
        images.append(Image.fromarray(joined).quantize(palette=palette,
                                                       dither=Image.Dither.NONE))
    if images:
        step_ms = round(1000.0 * (times[1] - times[0])) if len(times) > 1 else 200
        images[0].save(path, save_all=True, append_images=images[1:], duration=step_ms,
                       loop=0, optimize=False)


def plot_comparison(runs: Sequence[DemoRun], path: Path, title: str) -> None:
    """Both systems over the same window: the UAVs' mean AoI at the leader (log scale)
    and their mean tracking error, against time."""
    fig, (aoi_ax, error_ax) = plt.subplots(1, 2, figsize=(12, 4.2))
    for k, run in enumerate(runs):
        colour, label = _colour(k), f"{run.options.system} @ {run.options.rate:g} fps"
        start, end = run.epoch, run.epoch + run.measured_s
        series = [aoi_series(run.deliveries, uav, start, end, step=0.01)
                  for uav in run.options.uav_ids]
        if series:
            ages = np.mean([age for _, age in series], axis=0)
            aoi_ax.plot(series[0][0] - start, ages * 1e3, color=colour, lw=1.2, label=label)
        tracks = [_samples(run, uav) for uav in run.options.uav_ids]
        tracks = [s for s in tracks if len(s)]
        if tracks:
            grid = np.arange(0.0, run.measured_s, 0.05)
            errors = np.mean([np.interp(grid, s[:, COLUMNS["t"]], s[:, COLUMNS["error_m"]])
                              for s in tracks], axis=0)
            error_ax.plot(grid, errors, color=colour, lw=1.2, label=label)
    aoi_ax.set(yscale="log", xlabel="time in the window (s)", ylabel="mean AoI at the leader (ms)",
               title="age of the freshest frame")
    error_ax.set(xlabel="time in the window (s)", ylabel="mean tracking error (m)",
                 title="UAV-car ground distance")
    for ax in (aoi_ax, error_ax):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_plots(out: Path, run: DemoRun, gif: bool = True) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "trajectories.png", out / "aoi_hist.png", out / "error_hist.png"]
    plot_trajectories(run, paths[0])
    plot_histograms(run, paths[1], paths[2])
    if gif:
        paths.append(out / "world.gif")
        write_gif([run], paths[-1])
    return paths


def write_comparison(out: Path, runs: Sequence[DemoRun], title: str,
                     gif: bool = True) -> list[Path]:
    """comparison.png and, with ``gif``, world.gif with a panel per run."""
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "comparison.png"]
    plot_comparison(runs, paths[0], title)
    if gif:
        paths.append(out / "world.gif")
        write_gif(runs, paths[-1])
    return paths
