"""The kernel's IP reassembly state of one network namespace, from its ``/proc/net``.

Why a run needs it: a UDP baseline's frame is one datagram of about 35 fragments, and
the receiving namespace keeps every incomplete datagram (a fragment lost to a tail
drop) for ``net.ipv4.ipfrag_time`` (30 s). At 50 fps that is thousands of them, enough to
fill ``ipfrag_high_thresh`` (4 MB): while it is full, every new fragment is refused
(a ReasmFail) and no datagram arrives at all. The kernel has no way to flush that memory
(since Linux 4.17 nothing evicts a queue before its timer), so a run that inherits it
loses frames to the run before it; a fresh namespace starts empty. The counters
(``/proc/net/snmp``) and the memory in use (``/proc/net/sockstat``) are read per run to
show that it did start clean, and what reassembly did during its window.
"""

from __future__ import annotations

from dataclasses import dataclass

from wiswarm_zenoh.testbed.tc import run


@dataclass(frozen=True)
class Reassembly:
    """``/proc/net/snmp``'s Ip reassembly counters (cumulative in the namespace) and the
    incomplete datagrams held right now (``/proc/net/sockstat``'s FRAG line)."""

    requests: int  # ReasmReqds: fragments that needed reassembly
    oks: int  # ReasmOKs: datagrams reassembled
    fails: int  # ReasmFails: failures (a refused fragment, a queue that timed out)
    held: int  # incomplete datagrams held
    held_bytes: int  # the memory they hold

    def since(self, before: Reassembly) -> dict[str, float]:
        """The counters' growth since ``before``, as a run's channel counters."""
        return {"reasm_reqds": float(self.requests - before.requests),
                "reasm_oks": float(self.oks - before.oks),
                "reasm_fails": float(self.fails - before.fails)}


def parse(snmp: str, sockstat: str) -> Reassembly:
    """The state from the texts of ``/proc/net/snmp`` and ``/proc/net/sockstat``."""
    ip = [line.split()[1:] for line in snmp.splitlines() if line.startswith("Ip:")]
    if len(ip) != 2:
        raise ValueError("no Ip: header and values in /proc/net/snmp")
    values = dict(zip(*ip, strict=True))
    frag = next((line.split()[1:] for line in sockstat.splitlines()
                 if line.startswith("FRAG:")), None)
    if frag is None:
        raise ValueError("no FRAG: line in /proc/net/sockstat")
    held = dict(zip(frag[::2], frag[1::2], strict=True))
    return Reassembly(int(values["ReasmReqds"]), int(values["ReasmOKs"]),
                      int(values["ReasmFails"]), int(held["inuse"]), int(held["memory"]))


def reassembly(ns: str) -> Reassembly:
    """Namespace ``ns``'s reassembly state (root: ``ip netns exec``)."""
    snmp, _, sockstat = run("ip", "netns", "exec", ns, "sh", "-c",
                            "cat /proc/net/snmp; echo @@; cat /proc/net/sockstat"
                            ).partition("@@\n")
    return parse(snmp, sockstat)
