"""A process's TCP connections, read from /proc: what the testbed's caps steer into a
class of their own (``Channel.cap_flows_of``), found by the sockets the process holds."""

from __future__ import annotations

import contextlib
import os
import socket
import sys
from pathlib import Path

ESTABLISHED = "01"  # a socket's state in /proc/net/tcp
Flow = tuple[str, int, int]  # a TCP connection: remote address, local port, remote port


def tcp_flows(pid: int, local_addr: str) -> list[Flow]:
    """The established IPv4 TCP connections process ``pid`` holds from ``local_addr``:
    the sockets among its descriptors, looked up in its namespace's table. ValueError if
    there is no such process."""
    try:
        fds = os.listdir(f"/proc/{pid}/fd")
        table = Path(f"/proc/{pid}/net/tcp").read_text().splitlines()[1:]
    except FileNotFoundError:
        raise ValueError(f"no process {pid}") from None
    inodes = set()
    for fd in fds:
        with contextlib.suppress(OSError):  # closed meanwhile
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
            if target.startswith("socket:["):
                inodes.add(target[len("socket:["):-1])
    flows = []
    for line in table:
        _, local, remote, state, *rest = line.split()
        if state == ESTABLISHED and rest[5] in inodes and _address_of(local) == local_addr:
            flows.append((_address_of(remote), _port_of(local), _port_of(remote)))
    return flows


def _address_of(entry: str) -> str:
    """``0100007F:1F90`` (the address as the host's u32 in hex, a port) -> 127.0.0.1."""
    return socket.inet_ntoa(int(entry.split(":")[0], 16).to_bytes(4, sys.byteorder))


def _port_of(entry: str) -> int:
    return int(entry.split(":")[1], 16)
