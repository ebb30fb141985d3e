"""Optional libraries come by extra (``wiswarm_zenoh.extras``): the extras named there are
pyproject's, registering every command loads none of their libraries, and a command
whose extra is missing says which to install in one line, exit 2, before it starts.
(The wheel's base install, without any extra, is tried in test_wheel.py.)"""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from tests.test_light_nodes import HEAVY, PROBE
from wiswarm_zenoh.cli.main import main
from wiswarm_zenoh.extras import EXTRAS, MissingExtra, missing_extra, require

ROOT = Path(__file__).resolve().parents[1]
ABSENT = "wiswarm_no_such_library"


def test_the_extras_are_pyprojects_and_the_base_has_none_of_their_libraries() -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    optional = project["optional-dependencies"]
    assert set(EXTRAS) <= set(optional)
    assert set(EXTRAS) <= set(optional["all"][0].partition("[")[2].rstrip("]").split(","))
    assert {lib for libs in EXTRAS.values() for lib in libs} == set(HEAVY)
    base = " ".join(project["dependencies"])
    for distribution in ("opencv", "matplotlib", "aiohttp", "rosbags", "foxglove",
                         "cryptography", "pymavlink"):
        assert distribution not in base


@pytest.mark.parametrize("argv", [["demo"], ["experiment", "sweep"], ["--help"]])
def test_registering_every_command_loads_no_optional_library(argv: list[str]) -> None:
    probe = PROBE.replace("parser.parse_args(sys.argv[1:])", "")
    loaded = subprocess.run([sys.executable, "-c", probe, *argv], capture_output=True,
                            text=True, check=True).stdout.split()
    assert [name for name in HEAVY if name in loaded] == []


def test_a_missing_library_is_told_as_the_extra_that_brings_it(
        monkeypatch: pytest.MonkeyPatch) -> None:
    assert str(missing_extra(ModuleNotFoundError("x", name="cv2"))) == (
        "needs the tracking extra: pip install 'wiswarm-zenoh[tracking]'")
    assert missing_extra(ModuleNotFoundError("x", name="matplotlib.pyplot")).extra == "plots"
    assert missing_extra(ModuleNotFoundError("x", name="yaml")) is None  # a bug: not ours
    monkeypatch.setitem(EXTRAS, "ros2", (ABSENT,))
    with pytest.raises(MissingExtra, match=r"needs the ros2 extra: .*\[ros2\]"):
        require("ros2")


@pytest.mark.parametrize("argv, extra", [
    (["swarm-demo", "--duration", "1"], "plots"),
    (["leader", "--ros2"], "ros2"),
])
def test_a_command_whose_extra_is_missing_says_which_and_exits_2(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        argv: list[str], extra: str) -> None:
    monkeypatch.setitem(EXTRAS, extra, (ABSENT,))
    assert main(argv) == 2
    assert capsys.readouterr().err == (f"wiswarm {argv[0]}: needs the {extra} extra: "
                                       f"pip install 'wiswarm-zenoh[{extra}]'\n")
