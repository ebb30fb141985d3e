"""Where the leader's output goes on Zenoh: each poll to its follower's querier with the
control broadcast when due (each site's on its own key); each delivery to its follower's
``fresh`` key (while anyone listens), the delivery stream, a bridge and the application;
unanswered polls to the delivery stream; bad input to the log with its key; a follower's
silence and return to the log (a silence once it lasts: ``silence``)."""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping

import zenoh

from wiswarm_zenoh.core import (
    Answering,
    Delivered,
    Event,
    PollRequest,
    Rejected,
    Silent,
    Stale,
    TimedOut,
)
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.bridge import LeaderBridge
from wiswarm_zenoh.transport.delivery_stream import DeliveryStream
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.links import FollowerLink
from wiswarm_zenoh.transport.notify import notify
from wiswarm_zenoh.transport.silence import SilenceLog
from wiswarm_zenoh.transport.steady_gets import SteadyGet, SteadyGets
from wiswarm_zenoh.transport.telemetry import fresh_attachment

log = logging.getLogger("wiswarm_zenoh.transport.leader_node")


class Outlets:
    """Sends the core's polls and hands its events on (on the poll thread)."""

    def __init__(self, session: zenoh.Session, keys: SwarmKeys,
                 links: Mapping[str, FollowerLink], bad_input: BadInputLog,
                 on_delivery: Callable[[Delivered], None] | None,
                 clock: Callable[[], float],
                 present: Callable[[str], bool] = lambda follower: True) -> None:
        self._keys, self._links = keys, links
        self._silence = SilenceLog(present)  # present: still polled, by a leader that runs
        self._bad_input, self._on_delivery, self._clock = bad_input, on_delivery, clock
        self.deliveries = DeliveryStream(session, keys)
        self._session = session
        self._controls: dict[str | None, zenoh.Publisher] = {}  # by site, made when needed
        self.bridge: LeaderBridge | None = None
        self.steady: SteadyGets | None = None  # None: every poll on the callback path

    def send(self, request: PollRequest) -> SteadyGet | None:
        """Send a poll (and the control, when due); a steady one's get, to wait on."""
        controls = request.controls
        if controls is not None:
            for site, control in controls.items():
                self._control_publisher(site).put(control)
        link = self._links[request.follower]
        steady = self.steady
        if request.steady and steady is not None and not (steady.busy or steady.closed):
            return steady.send(link, request)
        link.poll(request.payload, request.poll_seq)
        return None

    def rejoined(self, follower: str) -> None:
        """``follower`` joined again: no warning of a silence the join ended."""
        self._silence.rejoined(follower)

    def _control_publisher(self, site: str | None) -> zenoh.Publisher:
        publisher = self._controls.get(site)
        if publisher is None:
            publisher = self._session.declare_publisher(self._keys.site_control(site),
                                                        express=True)
            self._controls[site] = publisher
        return publisher

    def hand_on(self, event: Event) -> None:
        match event:
            case Delivered(follower=follower):
                link = self._links.get(follower)
                if link is not None and link.listening:
                    link.fresh.put(event.payload, attachment=fresh_attachment(event))
                if self.deliveries.listening:
                    self.deliveries.add(event, event.delivered_at)
                if self.bridge is not None:
                    notify(self.bridge.deliver, event)
                if self._on_delivery is not None:
                    notify(self._on_delivery, event)
            case TimedOut(follower=follower, poll_seq=poll_seq):
                self.deliveries.add(event, self._clock())
                log.debug("poll %d of %s unanswered", poll_seq, follower)
            case Rejected(follower=follower, reason=reason):
                self._bad_input.report(self._keys.update(follower), reason)
            case Stale(follower=follower, reason=reason):  # late, after our own timeout
                self._bad_input.report(self._keys.update(follower), reason, expected=True)
            case Silent(follower=follower, answered_before=False):
                log.info("follower %s has not answered its first poll (not up yet, no "
                         "queryable, or no valid reply): probing it alone", follower)
            case Silent(follower=follower, polls=polls):
                self._silence.silent(follower, polls)
            case Answering(follower=follower, silent_for=silent_for):
                self._silence.answering(follower, silent_for)

    def close(self) -> None:
        self.deliveries.close()
        undeclare(*self._controls.values())
