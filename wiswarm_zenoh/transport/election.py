"""Which of a swarm's leaders polls: the oldest one alive.

Every leader process holds a liveliness token ``wiswarm/<swarm>/leaders/<name>/<start>``
(its start time in microseconds) and watches everyone's, history included. The active
leader is the one with the smallest (start, name): the first holder. A leader started
later (a standby, or a restarted one) then never pre-empts a running one, and every
leader reaches the same verdict from the tokens alone, with no message exchanged (two
starts in the same microsecond are told apart by name). When the active leader's token
goes (its process died: on loopback Zenoh sees the closed link at once; a lost link
within the session's lease), the next oldest takes over. A partition gives each side an
active leader; once it heals, each sees the other's token again and the younger steps
down, so two leaders poll for at most the time Zenoh takes to tell them of each other.
Start times come from each host's clock: hosts a few ms apart order leaders started at
least that far apart, which is all the rule needs.

A token that flaps (a router link that drops and comes back at once) must not hand the
swarm over and back: the active leader's token counts as gone only once it has stayed
away for ``grace`` (default a quarter of a second, a quarter of the 1 s takeover budget);
one back before then is logged as a flap and nothing changes. A leader appearing, or
any other token going, is judged at once: the younger of two active leaders steps down
without delay.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable

import zenoh

from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import ROOT, SwarmKeys, check_name
from wiswarm_zenoh.units import format_epoch

log = logging.getLogger(__name__)

Claim = tuple[int, str]  # (start in microseconds, name): the smallest leads
ASK_TIMEOUT = 2.0  # seconds: the routers answer at once; this bounds a start with none
START_ASKS = 3  # at the start, answers that timed out: asked again
START_SETTLE = 0.25  # seconds a leader that finds itself the oldest waits for the watch
TAKEOVER_GRACE = 0.25  # seconds the active leader's token must stay away to count as gone


class Election:
    """This leader's token, and the verdict from everyone's. ``on_change`` is called
    (on Zenoh's thread: keep it short) whenever the active leader changes."""

    def __init__(self, session: zenoh.Session, keys: SwarmKeys, name: str, started_us: int,
                 on_change: Callable[[], None], grace: float = TAKEOVER_GRACE) -> None:
        self.keys = keys
        self.claim: Claim = (started_us, check_name(name, "leader name"))
        self._on_change = on_change
        self._grace = grace
        self._lock = threading.Lock()
        self._claims: set[Claim] = {self.claim}
        self._leaving: dict[Claim, threading.Timer] = {}  # the active's token, gone lately
        self.flaps = 0  # times the active leader's token came back within the grace
        self._active = self.claim
        self._watched: set[Claim] = set()  # tokens the watch saw come and not go
        self._went: set[Claim] = set()  # tokens the watch saw go and not come back
        self._missed: set[Claim] = set()  # claims the last answer to recheck lacked
        self._judging = False  # until the start's verdict: the watch only takes notes
        self._noted = threading.Condition(self._lock)
        self._liveliness = liveliness = session.liveliness()
        # The watch (history included) first, then the asks, before and after declaring
        # our token, and the verdict from all of them. In peer mode a liveliness get can
        # lack a token that is there (eclipse-zenoh 1.10, once a peer reaches the token's
        # holder both directly and through the router: up to one answer in five on a busy
        # host, none on a quiet one or in client mode; bench_liveliness_answers.py),
        # while the watch, told of each declaration, does not miss it: what it saw come
        # stands until it sees it go. A token an answer holds but the watch saw go is
        # gone. A leader that finds itself the oldest waits START_SETTLE for the watch's
        # history still on its way: a standby never starts active.
        self._watch = liveliness.declare_subscriber(keys.leaders, self._on_token, history=True)
        before = self._ask()
        self._token = liveliness.declare_token(keys.leader(name, started_us))
        after = self._ask()
        if before is None and after is None:
            log.warning("no router said which leaders are there (%d asks timed out after "
                        "%.0f s): judging from the tokens seen from now on", 2 * START_ASKS,
                        ASK_TIMEOUT)
        with self._lock:
            self._claims |= ((before or set()) | (after or set())) - self._went
            self._noted.wait_for(lambda: min(self._claims) != self.claim, START_SETTLE)
            self._active = min(self._claims)
            self._judging = True

    @property
    def active(self) -> Claim:
        with self._lock:
            return self._active

    @property
    def leading(self) -> bool:
        return self.active == self.claim

    def _on_token(self, sample: zenoh.Sample) -> None:
        claim = _claim_of(str(sample.key_expr), self.keys.swarm)
        if claim is None:
            log.warning("leader token %s is not wiswarm/<swarm>/leaders/<name>/<start>: "
                        "ignored", sample.key_expr)
            return
        with self._lock:
            if sample.kind == zenoh.SampleKind.PUT:
                self._watched.add(claim)
                self._went.discard(claim)
                self._missed.discard(claim)
                leaving = self._leaving.pop(claim, None)
                if leaving is not None:
                    leaving.cancel()
                    self.flaps += 1
                    log.warning("the token of active leader %s went and came back within "
                                "%.0f ms (flap %d): it stays active", claim[1],
                                self._grace * 1e3, self.flaps)
                    return
                if claim != self.claim and claim[1] == self.claim[1]:
                    log.warning("another leader is named %s too (started at %d us): "
                                "the older of the two leads", claim[1], claim[0])
                self._claims.add(claim)
                self._noted.notify_all()
            elif claim != self.claim:  # our own token goes only when we close
                self._watched.discard(claim)
                self._went.add(claim)
                if self._judging and claim == self._active and self._grace > 0:
                    if claim not in self._leaving:
                        timer = threading.Timer(self._grace, self._gone, (claim,))
                        timer.daemon = True
                        self._leaving[claim] = timer
                        timer.start()
                    return
                self._claims.discard(claim)
            if not self._judging:
                return
        self._judge()

    def _ask(self) -> set[Claim] | None:
        """``_there``, asked again (up to START_ASKS in all) while it times out."""
        for _ in range(START_ASKS):
            if (there := self._there()) is not None:
                return there
        return None

    def _there(self) -> set[Claim] | None:
        """The leaders' claims whose tokens are there now; None if the answer timed out.
        (This session answers for its own token at once, so that one's presence proves
        nothing; a router that does not answer in time, on a busy host or going down,
        ends the get with an error reply, and the answer is then only part of it.)"""
        claims = set()
        for reply in self._liveliness.get(self.keys.leaders, timeout=ASK_TIMEOUT):
            if reply.ok is None:
                return None
            claim = _claim_of(str(reply.ok.key_expr), self.keys.swarm)
            if claim is not None:
                claims.add(claim)
        return claims

    def recheck(self) -> None:
        """Ask which leaders' tokens are there, and drop a claim that only an answer
        gave (the watch never saw its token) once two answers in a row lack it: a token
        that went before the watch could see it must not keep a standby standing by for
        ever. A claim the watch saw come stands until the watch sees it go: in peer mode
        an answer can lack a token that is there (see ``__init__``), and taking it for
        gone made a standby lead beside the active leader for good. An answer that timed
        out says nothing."""
        there = self._there()
        with self._lock:
            if there is None:
                self._missed = set()  # no answer: none in a row
                return
            lacked = (self._claims - there - self._watched - {self.claim}
                      - set(self._leaving))
            stale, self._missed = lacked & self._missed, lacked
            if not stale:
                return
            self._claims -= stale
        log.info("leader tokens gone unseen: %s", ", ".join(c[1] for c in sorted(stale)))
        self._judge()

    def _gone(self, claim: Claim) -> None:
        """The active leader's token stayed away for the grace: it is gone."""
        with self._lock:
            if self._leaving.pop(claim, None) is None:
                return  # it came back meanwhile
            self._claims.discard(claim)
        self._judge()

    def _judge(self) -> None:
        with self._lock:
            active = min(self._claims)
            changed, self._active = active != self._active, active
        if changed:
            log.info("leader %s (started %s) is active now%s", active[1],
                     format_epoch(active[0]), ": this process" if active == self.claim else "")
            self._on_change()

    def close(self) -> None:
        with self._lock:
            for timer in self._leaving.values():
                timer.cancel()
            self._leaving.clear()
        undeclare(self._watch, self._token)


def _claim_of(key: str, swarm: str) -> Claim | None:
    parts = key.split("/")
    if len(parts) != 5 or parts[0] != ROOT or parts[1] != swarm or parts[2] != "leaders" \
            or not parts[4].isdigit():
        return None
    try:
        return int(parts[4]), check_name(parts[3], "leader name")
    except ValueError:
        return None
