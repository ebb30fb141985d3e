"""Entering a named network namespace from Python (``ip netns`` names).

Python 3.11 has no ``os.setns``, so this calls libc's ``setns(2)`` on the namespace's
bind mount ``/var/run/netns/<name>``. The switch is per thread: threads the calling
thread starts afterwards inherit it, which is why a ``spawn`` child enters first and
only then opens its Zenoh session (whose runtime threads start inside the namespace).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

NETNS_DIR = Path("/var/run/netns")
CLONE_NEWNET = 0x40000000  # <linux/sched.h>

_libc = ctypes.CDLL(None, use_errno=True)
_libc.setns.argtypes = (ctypes.c_int, ctypes.c_int)
_libc.setns.restype = ctypes.c_int


def enter(ns: str) -> None:
    """Move the calling thread into network namespace ``ns`` (OSError says why not)."""
    if not ns or "/" in ns or ns in (".", ".."):
        raise OSError(f"invalid network namespace name {ns!r}")
    path = NETNS_DIR / ns
    try:
        fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
    except OSError as exc:
        raise OSError(exc.errno, f"network namespace {ns!r} not found: cannot open {path} "
                                 f"({exc.strerror})") from None
    try:
        _setns(fd, f"network namespace {ns!r}")
    finally:
        os.close(fd)


def _setns(fd: int, what: str) -> None:
    if _libc.setns(fd, CLONE_NEWNET) != 0:
        err = ctypes.get_errno()
        raise OSError(err, f"cannot enter {what}: {os.strerror(err)} "
                           "(entering a namespace needs root, CAP_SYS_ADMIN)")


@contextlib.contextmanager
def entered(ns: str) -> Iterator[None]:
    """The calling thread inside ``ns`` for the block, then back in the namespace it was
    in. Threads started inside stay there: a process that opens its first Zenoh session
    in the block has Zenoh's runtime in ``ns`` for good (a session opened before it was
    entered would still talk from where it was)."""
    home = os.open("/proc/thread-self/ns/net", os.O_RDONLY | os.O_CLOEXEC)
    try:
        enter(ns)
        try:
            yield
        finally:
            _setns(home, "the namespace the thread came from")
    finally:
        os.close(home)


def run_in(ns: str, target: Callable[..., object], *args: Any) -> None:
    """``enter(ns)`` then ``target(*args)``: a ``spawn`` child's target that runs a node
    inside one side of the channel (``run_child(run_in, (ns, target, *args), ready)``)."""
    enter(ns)
    target(*args)
