"""`wiswarm demo` as a new user runs it, without root: WiSwarm and then push at 50 fps
over the 20 Mbit/s shared link in user space, compared side by side.

Run as root (as CI does), the test drops to user ``nobody`` with ``setpriv`` (no
capabilities, no groups, no new privileges): a demo that needed root for anything
(namespaces, qdiscs, privileged ports) fails there. Run as anyone else, it runs as is.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from PIL import Image

from wiswarm_apps.tracking.plots import GIF_RESOLUTION_M
from wiswarm_apps.tracking.world import WorldConfig

ROOT = Path(__file__).resolve().parents[2]
NOBODY = 65534
# setpriv may still hold root's capabilities while it execs its command: ``env`` then
# execs Python as the unprivileged process that the demo and its children are.
SETPRIV = ("setpriv", f"--reuid={NOBODY}", f"--regid={NOBODY}", "--clear-groups",
           "--no-new-privs", "--inh-caps=-all", "--bounding-set=-all", "env")
UAVS, DURATION = 2, 5
PURELIB = sysconfig.get_paths()["purelib"]


def _unprivileged() -> tuple[tuple[str, ...], str]:
    """The command prefix and interpreter that run Python as an unprivileged user.

    As root: setpriv to nobody, with an interpreter nobody may run (this one, unless it
    lives under a private home, then the system's of the same version, given this
    environment's packages on PYTHONPATH)."""
    if os.geteuid() != 0:
        return (), sys.executable
    if shutil.which("setpriv") is None:
        pytest.skip("setpriv (util-linux) is missing: cannot drop root to run the demo")
    system_python = f"/usr/bin/python{sys.version_info.major}.{sys.version_info.minor}"
    for python in (sys.executable, system_python):
        probe = subprocess.run([*SETPRIV, python, "-c", "import os; print(os.geteuid())"],
                               capture_output=True, text=True, check=False, env=_env(Path("/")))
        if probe.returncode == 0 and probe.stdout.strip() == str(NOBODY):
            return SETPRIV, python
    pytest.skip(f"no Python {sys.version_info.major}.{sys.version_info.minor} that user "
                "nobody may run")


def _env(home: Path, paths: tuple[str, ...] = (str(ROOT), str(ROOT / "apps"), PURELIB)
         ) -> dict[str, str]:
    return {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": str(home),
            "MPLCONFIGDIR": str(home / ".matplotlib"), "LANG": "C.UTF-8",
            "PYTHONPATH": os.pathsep.join(paths)}


def _readable_code(prefix: tuple[str, ...], python: str, home: Path) -> tuple[str, ...]:
    """Where user nobody finds the project and its packages: where they are, or, for a
    checkout nobody may enter (a private temporary directory, as a fresh clone's), a
    mirror under ``home`` (packages hard-linked where the file system allows)."""
    probe = subprocess.run([*prefix, python, "-c",
                            "import wiswarm_zenoh, wiswarm_apps, zenoh, cv2"],
                           capture_output=True, check=False, env=_env(home))
    if probe.returncode == 0:
        return str(ROOT), str(ROOT / "apps"), PURELIB
    mirror = home / "code"
    for package in (ROOT / "wiswarm_zenoh", ROOT / "apps" / "wiswarm_apps"):
        shutil.copytree(package, mirror / "src" / package.name)
    linked = subprocess.run(["cp", "-al", PURELIB, str(mirror / "packages")],
                            capture_output=True, check=False)
    if linked.returncode != 0:  # another file system: copied instead
        shutil.rmtree(mirror / "packages", ignore_errors=True)
        shutil.copytree(PURELIB, mirror / "packages", symlinks=True)
    for directory in (mirror, *mirror.rglob("*")):
        if directory.is_dir():
            directory.chmod(0o755)
    return str(mirror / "src"), str(mirror / "packages")


@pytest.fixture(scope="module")
def comparison() -> Iterator[tuple[subprocess.CompletedProcess[str], Path]]:
    prefix, python = _unprivileged()
    home = Path(tempfile.mkdtemp(prefix="wiswarm-demo-"))  # under /tmp: nobody reaches it
    home.chmod(0o777)
    out = home / "run"
    try:
        paths = _readable_code(prefix, python, home)
        done = subprocess.run(
            [*prefix, python, "-m", "wiswarm_zenoh.cli.main", "demo", "--uavs", str(UAVS),
             "--duration", str(DURATION), "--warmup", "1", "--no-live", "--no-dashboard",
             "--out", str(out)],
            capture_output=True, text=True, timeout=240, check=False, cwd=home,
            env=_env(home, paths))
        yield done, out
    finally:
        shutil.rmtree(home)


def test_an_unprivileged_user_gets_the_comparison(
        comparison: tuple[subprocess.CompletedProcess[str], Path]) -> None:
    done, out = comparison
    assert done.returncode == 0, done.stderr[-3000:]
    if os.geteuid() == 0:  # the files are nobody's: it really ran as nobody
        assert (out / "summary.json").stat().st_uid == NOBODY
    summary = json.loads((out / "summary.json").read_text())
    systems = summary["systems"]
    assert list(systems) == ["wiswarm", "push"]
    for name, rate in (("wiswarm", 100), ("push", 50)):
        entry = systems[name]
        assert entry["channel"]["kind"] == "user" and entry["channel"]["rate_bps"] == 20_000_000
        assert entry["rate_hz"] == rate and set(entry["per_uav"]) == {"uav0", "uav1"}
        assert entry["measured_s"] == DURATION
    wiswarm, push = systems["wiswarm"], systems["push"]
    # The targets: push at 50 fps at least 10x staler and 4x worse at tracking.
    assert push["mean_aoi_s"] >= 10 * wiswarm["mean_aoi_s"]
    assert push["tracking_error_m"] >= 4 * wiswarm["tracking_error_m"]
    assert summary["push_over_wiswarm"]["mean_aoi"] == pytest.approx(
        push["mean_aoi_s"] / wiswarm["mean_aoi_s"])
    # Two UAVs share 21 ms frame times: about 45 ms; far from push's seconds.
    assert 0.02 < wiswarm["mean_aoi_s"] < 0.2 and wiswarm["in_view"] > 0.9


def test_it_prints_the_systems_side_by_side_and_draws_both(
        comparison: tuple[subprocess.CompletedProcess[str], Path]) -> None:
    done, out = comparison
    assert done.returncode == 0, done.stderr[-3000:]
    lines = done.stdout.splitlines()
    header = next(i for i, line in enumerate(lines) if "wiswarm@100fps" in line)
    assert "push@50fps" in lines[header] and "push / wiswarm" in lines[header]
    assert [line.split()[0] for line in lines[header + 1:header + 5]] == [
        "AoI", "AoI", "tracking", "car"]
    assert lines[header + 1].endswith("x")  # the ratio
    assert Image.open(out / "comparison.png").format == "PNG"
    arena = WorldConfig(n_cars=UAVS).arena
    panel = round(arena.width_m / GIF_RESOLUTION_M)
    with Image.open(out / "world.gif") as gif:  # both runs, side by side
        assert gif.n_frames == DURATION * 5 and gif.width == 2 * panel + 4
    for system in ("wiswarm", "push"):
        each = json.loads((out / system / "summary.json").read_text())
        assert each["system"] == system and set(each["per_uav"]) == {"uav0", "uav1"}
