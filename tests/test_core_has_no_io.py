"""The core stays sans-I/O: no module under wiswarm_zenoh/core imports a clock, socket,
thread, process, file or logging module (time comes in as ``now``)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

CORE = Path(__file__).resolve().parents[1] / "wiswarm_zenoh" / "core"
FORBIDDEN = {
    "time", "datetime", "socket", "socketserver", "ssl", "select", "selectors", "signal",
    "threading", "_thread", "asyncio", "concurrent", "queue", "sched", "subprocess",
    "multiprocessing", "os", "sys", "io", "pathlib", "shutil", "tempfile", "glob", "mmap",
    "logging", "urllib", "http", "ftplib", "smtplib", "zenoh", "cv2", "pymavlink",
    "serial", "requests", "matplotlib",
}


def imported_roots(source: str) -> set[str]:
    """Top-level names of every module ``source`` imports, however it spells it."""
    roots: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            roots.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            roots.add(node.module.split(".")[0])
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
              and node.func.id == "__import__" and node.args
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            roots.add(node.args[0].value.split(".")[0])
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
              and node.func.attr == "import_module"):
            roots.add("importlib.import_module")  # dynamic import: not allowed either
    return roots


MODULES = sorted(CORE.glob("*.py"))


def test_the_core_exists() -> None:
    assert {"leader.py", "follower.py", "policies.py", "wire.py"} <= {m.name for m in MODULES}


@pytest.mark.parametrize("module", MODULES, ids=lambda m: m.name)
def test_core_module_imports_no_io_or_clock_module(module: Path) -> None:
    bad = imported_roots(module.read_text(encoding="utf-8")) & (
        FORBIDDEN | {"importlib.import_module"}
    )
    assert not bad, f"{module.name} imports {sorted(bad)}"


@pytest.mark.parametrize("source", [
    "import time", "import os.path", "from time import monotonic", "from os import path as p",
    "import numpy, socket", "from concurrent.futures import ThreadPoolExecutor",
    "def f():\n    import threading", "__import__('time')",
    "import importlib\nimportlib.import_module('socket')",
])
def test_the_check_catches_every_spelling(source: str) -> None:
    assert imported_roots(source) & (FORBIDDEN | {"importlib.import_module"})


def test_the_check_allows_the_core_dependencies() -> None:
    source = "import math\nimport numpy as np\nfrom msgpack import packb\nfrom . import wire"
    assert not imported_roots(source) & FORBIDDEN
