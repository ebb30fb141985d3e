"""Zenoh's shared-memory files (``/dev/shm/<id>.zenoh``) whose processes are all gone.

Only a node given ``--shared-memory`` makes such files. Zenoh removes a segment when
its last user lets go of it, and sweeps orphans when a process starts using shared
memory; but what the last process of a host still held when it ended (by SIGKILL, or
segments Zenoh keeps for the process's lifetime, eclipse-zenoh/zenoh#2787) stays in
``/dev/shm`` until some later process does. So a session opened with shared memory on
starts ``watch()`` once per process: this file, run as a script (standard library only,
detached), waits for the node to end however it ends, then sweeps as Zenoh does.

A segment is an orphan when nobody holds its advisory lock: its creator and every
process that maps it hold a shared ``flock`` on it until they unmap it or end.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import select
import subprocess
import sys
from pathlib import Path

SEGMENTS = Path("/dev/shm")
_watched: set[int] = set()  # processes a sweeper already waits for


def sweep(directory: Path = SEGMENTS) -> list[str]:
    """Remove every Zenoh segment file in ``directory`` that no process holds; their
    names. The exclusive lock is held while the file goes, so that a process opening it
    meanwhile fails to lock it and takes another (as with Zenoh's own sweep)."""
    removed = []
    for path in directory.glob("*.zenoh"):
        if not path.stem.isdigit():
            continue
        try:
            fd = os.open(path, os.O_RDWR | os.O_NOFOLLOW)
        except OSError:  # gone meanwhile, or not ours to open
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # someone maps it
            os.close(fd)
            continue
        with contextlib.suppress(FileNotFoundError):
            path.unlink()
            removed.append(path.name)
        os.close(fd)
    return removed


def watch(pid: int | None = None, directory: Path = SEGMENTS) -> None:
    """Sweep ``directory`` once process ``pid`` (this one) has ended: a detached sweeper,
    started once a process."""
    pid = os.getpid() if pid is None else pid
    if pid in _watched:
        return
    _watched.add(pid)
    # -I -S: a bare interpreter (this file needs nothing else), started in a blink.
    subprocess.run([sys.executable, "-I", "-S", __file__, str(pid), str(directory)],
                   check=False, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)


def _wait_then_sweep(pid: int, directory: Path) -> None:
    """Detach (the caller returns at once), wait for ``pid`` to end, sweep."""
    if os.fork():
        os._exit(0)
    os.setsid()  # Ctrl-C at the node's terminal is not for the sweeper
    try:
        pidfd = os.pidfd_open(pid)
    except ProcessLookupError:
        pass
    else:
        select.select([pidfd], [], [])  # readable once the process has ended
    sweep(directory)


if __name__ == "__main__":
    _wait_then_sweep(int(sys.argv[1]), Path(sys.argv[2]))
