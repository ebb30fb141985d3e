"""The wheel a user installs: built from this checkout, installed with its dependencies
into an empty virtual environment (from the package index, as ``pip install`` does),
it gives the API and a working ``wiswarm``, and its applications as ``wiswarm_apps``,
never as a top-level ``apps`` that would collide with another project's."""

from __future__ import annotations

import subprocess
import sys
import sysconfig
from pathlib import Path

import wiswarm_zenoh

ROOT = Path(__file__).resolve().parents[1]


def run(*argv: str | Path, cwd: Path) -> str:
    done = subprocess.run([str(a) for a in argv], capture_output=True, text=True, cwd=cwd,
                          timeout=300, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def test_the_built_wheel_installs_a_working_wiswarm_and_api(tmp_path: Path) -> None:
    run(sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", tmp_path / "dist",
        ROOT, cwd=tmp_path)
    [wheel] = (tmp_path / "dist").glob("wiswarm_zenoh-*.whl")
    run(sys.executable, "-m", "venv", tmp_path / "venv", cwd=tmp_path)
    bin_dir = tmp_path / "venv" / "bin"
    run(bin_dir / "python", "-m", "pip", "install", "-q", wheel, cwd=tmp_path)

    names = run(bin_dir / "python", "-c",
                "import wiswarm_zenoh, wiswarm_apps.tracking.cli; print(*wiswarm_zenoh.__all__)",
                cwd=tmp_path)
    assert names.split() == wiswarm_zenoh.__all__
    assert "experiment" in run(bin_dir / "wiswarm", "--help", cwd=tmp_path)
    purelib = Path(run(bin_dir / "python", "-c",
                       "import sysconfig; print(sysconfig.get_path('purelib'))",
                       cwd=tmp_path).strip())
    assert purelib != Path(sysconfig.get_path("purelib"))  # the fresh one, not this one
    ours = {p.name for p in purelib.iterdir()} & {"apps", "wiswarm_apps", "wiswarm_zenoh"}
    assert ours == {"wiswarm_apps", "wiswarm_zenoh"}
