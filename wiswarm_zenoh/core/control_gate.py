"""Which control messages a follower obeys: plausible ones, newest first.

A control message carries its leader's epoch and clock (``lt``). The follower knows
that leader's clock from the polls it answered (each poll carries the leader's send
time), so a genuine message is stamped within a few one-way delays of it. Anything
further off, ahead or behind, is refused: a forged far-future stamp cannot block later
genuine control, and a replay older than the window cannot move the follower back.

``window`` (default 1 s, ``FollowerConfig.control_window``): the estimate lags the
leader's clock by the last poll's one-way delay, and a genuine message's stamp by its
own, so genuine control is off by the difference of two one-way delays plus the drift
since the last poll: milliseconds on a LAN, tens to a few hundred on a congested
channel or a WAN (a poll answered later than the leader's 0.3 s timeout is useless).
A leader that has not polled this follower yet (just restarted; the push baseline,
which never polls) is judged against the follower's own clock: hosts synchronised by
NTP are within the window; others are obeyed from that leader's first poll on.

Control of an epoch older than the leader that polls this follower now (the main
poller, see ``pollers``) and whose control it obeyed is ignored: a leader that was taken
over from, or a dead one whose last messages arrive late, no longer steers. (A poll
alone does not bar older control: a stray poll with a high epoch must not silence the
leader.) Among plausible messages the newest arrival wins, except that a message of an
epoch already obeyed must be newer, by (leader time, seq), than the last one of it:
replays and reordered messages are ignored. So a rogue message that is plausible (only
a forger who reads the swarm's traffic can stamp one) holds the follower until the
leader's next control (another epoch), or at most ``window`` seconds (the leader's own).
A forged poll moves its epoch's clock only until that leader's next poll, and a control
obeyed on the moved clock, once ahead of the window, no longer bars the leader's.
"""

from __future__ import annotations

from collections import OrderedDict

from wiswarm_zenoh.core.errors import WireError
from wiswarm_zenoh.core.messages import Control
from wiswarm_zenoh.core.pollers import Pollers

MAX_EPOCHS = 8  # epochs whose last control is remembered


class ControlGate:
    """Judges control messages against the clocks of the pollers a follower knows."""

    def __init__(self, pollers: Pollers, window: float) -> None:
        self.window = window
        self.rejected = 0
        self.stale = 0
        self._pollers = pollers
        self._last: OrderedDict[int, tuple[float, int]] = OrderedDict()

    def admit(self, control: Control, now: float) -> bool:
        """True if ``control`` is to be obeyed; False if it is not newer than what this
        follower obeyed from its epoch. Raises ``WireError`` (and counts it) if its
        leader time is outside the window."""
        poller = self._pollers.get(control.epoch)
        expected = now if poller is None else poller.leader_clock(now)
        off = control.leader_time - expected
        if abs(off) > self.window:
            self.rejected += 1
            whose = ("this follower's clock (no poll of that epoch yet)" if poller is None
                     else "its leader's clock as known from its polls")
            raise WireError(f"control of epoch {control.epoch} stamped {off:+.3f} s off "
                            f"{whose}, beyond the {self.window:g} s window")
        main = self._pollers.main
        if main is not None and control.epoch < main.epoch and main.epoch in self._last \
                and now - main.received_at <= self._pollers.expiry:
            self.stale += 1  # a leader taken over from: its last words are not obeyed
            return False
        key = (control.leader_time, control.seq)
        last = self._last.get(control.epoch)
        if last is not None and last[0] > expected + self.window:
            last = None  # obeyed on a clock a forged poll had moved: it bars nothing now
        if last is not None and key <= last:
            self.stale += 1
            return False
        self._last[control.epoch] = key
        self._last.move_to_end(control.epoch)
        if len(self._last) > MAX_EPOCHS:
            self._last.popitem(last=False)
        return True
