"""The documentation site: it builds with ``mkdocs build --strict`` (a broken link, a
missing anchor, a page outside the nav or an API name that does not resolve fails), every
public name it documents has a docstring (mkdocstrings hides the ones without, silently),
its code runs as printed, and its command reference names every ``wiswarm`` command."""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import griffe
import pytest

from wiswarm_zenoh.cli.main import build_parser
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def test_the_site_builds_strict(tmp_path: Path) -> None:
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT, capture_output=True, text=True, timeout=120, env=env)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    api = (tmp_path / "site" / "api.html").read_text(encoding="utf-8")
    for name in ("wiswarm_zenoh.transport.FollowerNode", "wiswarm_zenoh.transport.LeaderNode",
                 "wiswarm_zenoh.core.Leader.next_poll"):
        assert f'id="{name}"' in api, name


def _documented_modules() -> list[str]:
    """The modules the API page renders (its ``::: module`` lines)."""
    page = (DOCS / "api.md").read_text(encoding="utf-8")
    return re.findall(r"^::: (\S+)\s*$", page, re.M)


def _undocumented(obj: griffe.Object | griffe.Alias, path: str) -> Iterator[str]:
    """Public names under ``obj`` (a class, function or module attribute) with no docstring:
    the object itself and, for a class, the functions and properties it defines."""
    if not obj.docstring or not obj.docstring.value.strip():
        yield path
    if obj.is_class:
        for name, member in obj.members.items():
            if name.startswith("_") or member.is_alias or not (
                    member.is_function or "property" in member.labels):
                continue
            if not member.docstring or not member.docstring.value.strip():
                yield f"{path}.{name}"


def test_every_name_the_api_page_documents_has_a_docstring() -> None:
    modules = _documented_modules()
    assert "wiswarm_zenoh" in modules and "wiswarm_zenoh.core" in modules
    package = griffe.load("wiswarm_zenoh", search_paths=[str(ROOT)], resolve_aliases=True)
    missing: list[str] = []
    for dotted in modules:
        module = package if dotted == "wiswarm_zenoh" else package[dotted.split(".", 1)[1]]
        if not module.docstring:
            missing.append(dotted)
        for name in module.exports or []:
            if name.startswith("__"):
                continue  # __version__ and the like
            member = module.members[name]
            target = member.final_target if member.is_alias else member
            missing += _undocumented(target, f"{dotted}.{name}")
    assert not missing, f"public names without a docstring: {missing}"


def _code_blocks(page: Path, language: str) -> list[str]:
    text = page.read_text(encoding="utf-8")
    return re.findall(rf"^```{language}\n(.*?)^```", text, re.M | re.S)


def test_the_core_example_is_the_readmes_and_runs() -> None:
    page = DOCS / "getting-started.md"
    readme = ROOT / "README.md"
    core = [b for b in _code_blocks(page, "python") if "from wiswarm_zenoh.core import" in b
            and "Follower(" in b]
    assert len(core) == 1
    assert core[0] in _code_blocks(readme, "python"), "README and docs differ"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(core[0], str(page), "exec"), {})
    assert sum(": update " in line for line in out.getvalue().splitlines()) > 150


def test_the_embedding_example_delivers_and_steers() -> None:
    """The one-process example of getting started: a follower and a leader on one peer
    session, as printed (it opens no router)."""
    page = DOCS / "getting-started.md"
    [block] = [b for b in _code_blocks(page, "python") if "FollowerNode(" in b
               and "LeaderNode(" in b]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(block, str(page), "exec"), {"__name__": "__main__"})
    lines = out.getvalue().splitlines()
    assert "joined: uav1" in lines
    assert sum(line.startswith("uav1: b'reading ") for line in lines) >= 5
    assert any(line.startswith("uav1 told to fly") for line in lines)
    assert any("FollowerStats(follower='uav1'" in line for line in lines)


def test_the_two_process_example_talks_through_a_router(tmp_path: Path) -> None:
    """follower.py and leader.py of getting started, each a process as printed, through
    ``wiswarm router`` (on a free port, and a swarm of their own, nothing else changed)."""
    page = DOCS / "getting-started.md"
    blocks = _code_blocks(page, "python")
    [follower] = [b for b in blocks if b.startswith("# follower.py")]
    [leader] = [b for b in blocks if b.startswith("# leader.py")]
    port = free_tcp_port()
    swarm = f"docs{port}"
    for name, code in (("follower.py", follower), ("leader.py", leader)):
        assert "tcp/127.0.0.1:7447" in code and '"s1"' in code
        code = code.replace("tcp/127.0.0.1:7447", f"tcp/127.0.0.1:{port}")
        (tmp_path / name).write_text(code.replace('"s1"', f'"{swarm}"'))
    wiswarm = Path(sys.executable).with_name("wiswarm")
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}  # what the follower said before its end
    router = subprocess.Popen(
        [str(wiswarm), "router", "-l", f"tcp/127.0.0.1:{port}", "--no-multicast-scouting"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    started = [router]
    try:
        assert router.stdout is not None
        assert "listening" in router.stdout.readline()
        follower_process = subprocess.Popen(
            [sys.executable, "follower.py"], cwd=tmp_path, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, text=True, env=env)
        started.append(follower_process)
        done = subprocess.run([sys.executable, "leader.py"], cwd=tmp_path,
                              capture_output=True, text=True, timeout=60, env=env)
        assert done.returncode == 0, done.stderr[-2000:]
        lines = done.stdout.splitlines()
        assert "joined: uav1" in lines
        assert sum(line.startswith("uav1: my sensor at ") for line in lines) >= 20
        assert any(line.startswith("uav1 mean AoI") for line in lines)
        follower_process.terminate()
        said, _ = follower_process.communicate(timeout=30)
        assert "fly to [(" in said
    finally:
        for process in reversed(started):
            if process.poll() is None:
                process.terminate()
                process.wait(30)


def _commands(parser: argparse.ArgumentParser, prefix: str) -> Iterator[str]:
    """Every leaf command under ``parser``: ``wiswarm router``, ``wiswarm sim wifi``..."""
    subparsers = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subparsers:
        yield prefix
    for action in subparsers:
        for name, child in action.choices.items():
            yield from _commands(child, f"{prefix} {name}")


@pytest.mark.parametrize("page", ["reference/cli.md"])
def test_the_command_reference_names_every_command(page: str) -> None:
    text = (DOCS / page).read_text(encoding="utf-8")
    missing = [c for c in _commands(build_parser(), "wiswarm") if f"`{c}`" not in text]
    assert not missing, f"{page} does not name {missing}"


def test_the_readmes_links_reach_files() -> None:
    """The README's relative links (into docs/, read on GitHub too) name files that exist."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    targets = re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", text)
    assert targets
    missing = [t for t in targets if not (ROOT / t).is_file()]
    assert not missing, missing
