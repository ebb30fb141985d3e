"""Building the ns-3 WiFi scenario (``ns3/wifi_medium.cc``) against the system's ns-3
(Debian: ``ns3``, ``libns3-dev``, ``libgsl-dev``), once per version of its source: the
binary is cached under ``$XDG_CACHE_HOME/wiswarm-zenoh`` (``~/.cache``) by the source's
hash, never committed."""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import subprocess
from importlib import resources
from pathlib import Path

log = logging.getLogger(__name__)

NS3_MODULES = ("ns3-wifi", "ns3-mobility", "ns3-network", "ns3-core", "ns3-propagation",
               "ns3-spectrum")
INSTALL_HINT = "install ns-3 (Debian: apt-get install ns3 libns3-dev libgsl-dev)"


class Ns3Unavailable(Exception):
    """The scenario cannot be built here (no compiler, pkg-config or ns-3)."""


def source() -> bytes:
    return resources.files("wiswarm_zenoh.testbed.ns3").joinpath("wifi_medium.cc").read_bytes()


def cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "wiswarm-zenoh"


def unavailable_reason() -> str | None:
    """Why the scenario cannot be built here, or None if it can (or is built already)."""
    if binary_path().exists():
        return None
    missing = [tool for tool in ("g++", "pkg-config") if shutil.which(tool) is None]
    if missing:
        return f"{' and '.join(missing)} not found: {INSTALL_HINT}"
    found = subprocess.run(["pkg-config", "--exists", *NS3_MODULES], check=False)
    if found.returncode != 0:
        return f"ns-3's development files are missing (pkg-config {NS3_MODULES[0]}): " \
               f"{INSTALL_HINT}"
    return None


def binary_path() -> Path:
    digest = hashlib.sha256(source()).hexdigest()[:16]
    return cache_dir() / f"wifi_medium-{digest}"


def scenario_binary() -> Path:
    """The built scenario, compiled now if this source has not been (about 10 s)."""
    target = binary_path()
    if target.exists():
        return target
    reason = unavailable_reason()
    if reason is not None:
        raise Ns3Unavailable(reason)
    target.parent.mkdir(parents=True, exist_ok=True)
    src = target.with_suffix(".cc")
    src.write_bytes(source())
    libs = subprocess.run(["pkg-config", "--libs", *NS3_MODULES], capture_output=True,
                          text=True, check=True).stdout.split()
    partial = target.with_name(f"{target.name}.{os.getpid()}.tmp")
    log.info("building the ns-3 WiFi scenario (once): %s", target)
    done = subprocess.run(["g++", "-O2", "-std=c++17", "-w", "-I/usr/include", "-o",
                           str(partial), str(src), *libs],
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        partial.unlink(missing_ok=True)
        raise Ns3Unavailable(f"building {src} failed: {done.stderr.strip()[-2000:]}")
    os.replace(partial, target)  # atomic: concurrent builders both end with one binary
    return target
