"""The wheel a user installs: built from this checkout, installed without extras into an
empty virtual environment (its dependencies from the package index, as ``pip install
wiswarm-zenoh`` does), it is what a follower on a drone's computer gets: small, none of
the libraries an extra brings, the API and the node commands working, and a command
that needs an extra saying which in one line, exit 2. Its applications come as
``wiswarm_apps``, never as a top-level ``apps`` that would collide with another
project's."""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

import wiswarm_zenoh
from tests.test_light_nodes import HEAVY

ROOT = Path(__file__).resolve().parents[1]
MOST_MB = 150  # the base install's site-packages (pip and setuptools included)


# Without the developer's PYTHONPATH (a checkout's own path): the fresh venv sees only
# what it installed, and its pip no wheel built in that checkout (its .egg-info).
ENV = {name: value for name, value in os.environ.items() if name != "PYTHONPATH"}


def run(*argv: str | Path, cwd: Path, code: int = 0) -> subprocess.CompletedProcess[str]:
    done = subprocess.run([str(a) for a in argv], capture_output=True, text=True, cwd=cwd,
                          env=ENV, timeout=600, check=False)
    assert done.returncode == code, done.stderr[-2000:]
    return done


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The bin directory of a fresh venv with the wheel installed, no extras."""
    tmp = tmp_path_factory.mktemp("wheel")
    run(sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", tmp / "dist", ROOT,
        cwd=tmp)
    [wheel] = (tmp / "dist").glob("wiswarm_zenoh-*.whl")
    run(sys.executable, "-m", "venv", tmp / "venv", cwd=tmp)
    bin_dir = tmp / "venv" / "bin"
    run(bin_dir / "python", "-m", "pip", "install", "-q", wheel, cwd=tmp)
    return bin_dir


def test_the_base_install_is_small_and_has_no_extra(base: Path) -> None:
    purelib = Path(run(base / "python", "-c",
                       "import sysconfig; print(sysconfig.get_path('purelib'))",
                       cwd=base).stdout.strip())
    assert purelib != Path(sysconfig.get_path("purelib"))  # the fresh one, not this one
    size = sum(p.stat().st_size for p in purelib.rglob("*") if p.is_file()) / 2**20
    assert size <= MOST_MB, f"{size:.0f} MB in {purelib}"
    found = run(base / "python", "-c", "import importlib.util as u, sys; "
                "print(*[n for n in sys.argv[1:] if u.find_spec(n)])", *HEAVY,
                cwd=base).stdout.split()
    assert found == []
    ours = {p.name for p in purelib.iterdir()} & {"apps", "wiswarm_apps", "wiswarm_zenoh"}
    assert ours == {"wiswarm_apps", "wiswarm_zenoh"}


def test_the_api_and_the_node_commands_work_there(base: Path) -> None:
    names = run(base / "python", "-c", "from wiswarm_zenoh import Follower, Leader, Observer; "
                "import wiswarm_zenoh; print(*wiswarm_zenoh.__all__)", cwd=base).stdout
    assert names.split() == wiswarm_zenoh.__all__
    for command in ("follower", "leader", "router"):
        assert "usage: wiswarm " + command in run(base / "wiswarm", command, "--help",
                                                  cwd=base).stdout
    assert "experiment" in run(base / "wiswarm", "--help", cwd=base).stdout


@pytest.mark.parametrize("argv, extra", [(["demo"], "tracking"),
                                         (["experiment", "sweep"], "plots")])
def test_a_command_whose_extra_is_missing_says_which_in_one_line(
        base: Path, argv: list[str], extra: str) -> None:
    done = run(base / "wiswarm", *argv, cwd=base, code=2)
    assert done.stderr == (f"wiswarm {argv[0]}: needs the {extra} extra: "
                           f"pip install 'wiswarm-zenoh[{extra}]'\n")
