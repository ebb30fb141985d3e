"""Layers: nothing in the middleware imports the CLI above it, nor an application (only
the CLI runs them); ``transport`` is the Zenoh shell and imports no program, experiment
or tool; the CLI imports what it runs (no module named in a string for ``importlib``);
applications use only what the middleware's packages export (never a module inside
them); tests use no private names. Read from the sources, so a new import anywhere is
judged."""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "wiswarm_zenoh"
# What an application may import from: the middleware's packages, by what they export
# (``options``: what a command line built on it needs, as ``wiswarm``'s own uses).
PUBLIC = {"wiswarm_zenoh", "wiswarm_zenoh.core", "wiswarm_zenoh.transport",
          "wiswarm_zenoh.programs", "wiswarm_zenoh.experiments", "wiswarm_zenoh.testbed",
          "wiswarm_zenoh.baselines", "wiswarm_zenoh.options",
          "wiswarm_zenoh.dashboard", "wiswarm_zenoh.ros2", "wiswarm_zenoh.recording"}


def imports(path: Path) -> Iterator[tuple[str, list[str]]]:
    """(module, names) of every absolute import in ``path``."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, []
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.module, [alias.name for alias in node.names]


def sources(directory: Path) -> list[Path]:
    return sorted(directory.rglob("*.py"))


# What the Zenoh shell may import from the middleware: the core and the small helpers
# at the bottom. Not ``security`` nor ``ros2``, which build on it: the TLS checks of a
# session's files are its own (``transport.tls_files``), so no import circle runs
# through it.
SHELL_BELOW = {"wiswarm_zenoh.core", "wiswarm_zenoh.transport", "wiswarm_zenoh.units",
               "wiswarm_zenoh.usage"}


@pytest.mark.parametrize("module", [p for p in sources(PACKAGE) if "cli" not in p.parts],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_nothing_below_the_cli_imports_it(module: Path) -> None:
    upward = [m for m, _ in imports(module) if m.startswith("wiswarm_zenoh.cli")]
    assert not upward, f"{module.name} imports {upward}"


@pytest.mark.parametrize("module", [p for p in sources(PACKAGE) if "cli" not in p.parts],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_the_middleware_imports_no_application(module: Path) -> None:
    upward = [m for m, _ in imports(module) if m.split(".")[0] in ("wiswarm_apps", "apps")]
    assert not upward, f"{module.name} imports {upward}"


@pytest.mark.parametrize("module", sources(PACKAGE / "transport"),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_transport_is_the_zenoh_shell_only(module: Path) -> None:
    beyond = [m for m, _ in imports(module) if m.startswith("wiswarm_zenoh")
              and ".".join(m.split(".")[:2]) not in SHELL_BELOW]
    assert not beyond, f"{module.name} imports {beyond}"


@pytest.mark.parametrize("module", sources(PACKAGE / "core") + sources(PACKAGE / "sim"),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_the_core_and_the_simulator_run_no_program_or_experiment(module: Path) -> None:
    upward = [m for m, _ in imports(module)
              if m.startswith(("wiswarm_zenoh.programs", "wiswarm_zenoh.experiments"))]
    assert not upward, f"{module.name} imports {upward}"


@pytest.mark.parametrize("module", sources(PACKAGE / "cli"), ids=lambda p: str(p.relative_to(ROOT)))
def test_the_cli_imports_what_it_runs(module: Path) -> None:
    """No module loaded by name: every link from the CLI is an import this test sees."""
    tree = ast.parse(module.read_text(encoding="utf-8"))
    named = [node.value for node in ast.walk(tree) if isinstance(node, ast.Constant)
             and isinstance(node.value, str)
             and re.fullmatch(r"(wiswarm_zenoh|wiswarm_apps|apps)(\.\w+)+(:\w+)?", node.value)]
    assert not named, f"{module.name} names modules in strings: {named}"
    assert "importlib" not in {m.split(".")[0] for m, _ in imports(module)}


def test_the_cli_reaches_the_application_and_the_studies() -> None:
    """The links the CLI used to make by name are imports now."""
    linked = {m for path in sources(PACKAGE / "cli") for m, _ in imports(path)}
    assert {"wiswarm_apps.tracking", "wiswarm_apps.tracking.cli"} <= linked


@pytest.mark.parametrize("module", sources(ROOT / "apps"), ids=lambda p: str(p.relative_to(ROOT)))
def test_applications_import_only_what_the_packages_export(module: Path) -> None:
    inside = [m for m, _ in imports(module)
              if m.startswith("wiswarm_zenoh") and m not in PUBLIC]
    assert not inside, f"{module.name} reaches into {inside}"


@pytest.mark.parametrize("module", sources(ROOT / "tests") + sources(ROOT / "apps"),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_no_private_name_is_imported(module: Path) -> None:
    private = [f"{m}.{n}" for m, names in imports(module) for n in names
               if m.startswith(("wiswarm_zenoh", "wiswarm_apps")) and n.startswith("_")]
    assert not private, f"{module.name} imports {private}"


@pytest.mark.parametrize("source, judged", [
    ("from wiswarm_zenoh.core.wire import _decode", ["wiswarm_zenoh.core.wire"]),
    ("import wiswarm_zenoh.transport.links", ["wiswarm_zenoh.transport.links"]),
    ("from wiswarm_zenoh.transport import LeaderNode", ["wiswarm_zenoh.transport"]),
])
def test_the_reader_sees_each_spelling(tmp_path: Path, source: str, judged: list[str]) -> None:
    path = tmp_path / "m.py"
    path.write_text(source)
    assert [m for m, _ in imports(path)] == judged
