"""Whom the leader polls next: the policy's pick over the peer table's columns."""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence

import numpy as np

from wiswarm_zenoh.core.ages import (
    ages_in_slots,
    array_ages_in_slots,
    array_fresh_ages_in_slots,
    fresh_ages_in_slots,
)
from wiswarm_zenoh.core.peers import IntArray, PeerTable
from wiswarm_zenoh.core.policies import FloatArray, IndexPolicy, Policy
from wiswarm_zenoh.core.poll_records import Pick


def choose(table: PeerTable, policy: Policy, slot: float, now: float,
           busy: Collection[int] = ()) -> int:
    """The policy's pick among followers that answer; a silent one only when its probe
    is due (or when every follower is silent). ``busy``: followers with a poll out
    already (a leader keeping several out), left out; not all of them."""
    if busy:
        return _choose_among(table, policy, slot, now, busy)
    if not table.silent:
        return pick(table, policy, slot, now, None)
    due = table.first_probe()
    if table.probe_at[due] <= now or table.silent == len(table):
        return due
    live = table.live()
    return int(live[pick(table, policy, slot, now, live)])


def _choose_among(table: PeerTable, policy: Policy, slot: float, now: float,
                  busy: Collection[int]) -> int:
    """``choose`` among the followers not in ``busy``."""
    free = [i for i in range(len(table)) if i not in busy]
    silent = [i for i in free if table.p[i] <= 0.0]
    if silent:
        due = min(silent, key=table.probe_at.__getitem__)
        if table.probe_at[due] <= now or len(silent) == len(free):
            return due
    live = [i for i in free if table.p[i] > 0.0]
    return live[pick(table, policy, slot, now, live)]


def pick(table: PeerTable, policy: Policy, slot: float, now: float,
         live: list[int] | IntArray | None) -> int:
    """The policy's pick among all followers, or among those in ``live`` (an index into
    it), by ages in slots; plain floats for a few followers, numpy for many."""
    if table.plain_loops:
        w: Sequence[float] = table.w
        p: Sequence[float] = table.p
        tau: Sequence[float] = table.tau
        due: Sequence[float] = table.due
        interval: Sequence[float] = table.interval
        ready: Sequence[float] = table.ready
        if not (table.unfresh or table.known_intervals):
            if live is not None:
                w, p, tau = ([column[i] for i in live] for column in (w, p, tau))
            return policy.choose_in_lists(w, p, fresh_ages_in_slots(tau, now, slot))
        if live is not None:
            w, p, tau, due, interval, ready = ([column[i] for i in live] for column
                                               in (w, p, tau, due, interval, ready))
        return policy.choose_in_lists(w, p, ages_in_slots(tau, due, interval, ready, now,
                                                          slot))
    wa, pa, taua, duea, intervala, readya = table.arrays()
    if live is not None:
        wa, pa, taua, duea, intervala, readya = (
            a[live] for a in (wa, pa, taua, duea, intervala, readya))
    return policy.choose(wa, pa, _array_ages(table, taua, duea, intervala, readya, now,
                                             slot))


def pick_after(table: PeerTable, policy: IndexPolicy, slot: float, poll_seq: int,
               polled: int, at: float) -> Pick | None:
    """Whom to poll after the poll ``poll_seq`` of the follower at ``polled``, if its
    reply comes at ``at``: the best of the others by the policy's index, with its value
    (to weigh the polled follower's new index against when the reply comes:
    ``still_holds``). None when that cannot be decided ahead: a single follower, or a
    silent one (whose probes ``choose`` times)."""
    if len(table) < 2 or table.silent:
        return None
    if table.plain_loops:
        values = policy.indices(table.w, table.p, _ages(table, at, slot))
        values[polled] = -math.inf
        best = max(values)
        choice = values.index(best)  # the first of equals, as ``choose`` takes it
    else:
        wa, pa, taua, duea, intervala, readya = table.arrays()
        indices = policy.index(wa, pa, _array_ages(table, taua, duea, intervala, readya, at,
                                                   slot))
        indices[polled] = -np.inf
        choice = int(indices.argmax())
        best = float(indices[choice])
    follower = table.ids[polled]
    table.watch(follower)
    peer = table.peers[follower]
    age = None if table.unfresh or table.known_intervals else \
        policy.age_below(best, table.w[polled], peer.reliability.after(True))
    if age is None:
        return Pick(poll_seq, polled, at, slot, choice, best, policy)
    # (+1 us: times of 1.7e9 s round to 0.24 us; its clock's offset is as it is until
    # this very reply is judged)
    holds_from = at - age * slot + 1e-6
    return Pick(poll_seq, polled, at, slot, choice, best, policy, holds_from,
                peer.clock.from_leader(holds_from))


def still_holds(pick: Pick, table: PeerTable, now: float) -> bool:
    """Whether ``pick`` is what ``choose`` would pick now that the polled follower's
    answer is in: it came by the time the pick assumed (within a slot), no other
    follower's row changed since, and the polled follower's new index at the pick's
    time, from its row as the policy reads it, does not beat the pick."""
    if now > pick.at + pick.slot or table.disturbed:
        return False
    i = pick.polled
    ages = ages_in_slots([table.tau[i]], [table.due[i]], [table.interval[i]],
                         [table.ready[i]], pick.at, pick.slot)
    value = pick.policy.indices([table.w[i]], [table.p[i]], ages)[0]
    return value < pick.value or (value == pick.value and i > pick.choice)  # ties: first


def holds_on_answer(pick: Pick, table: PeerTable, tau: float, p: float, now: float) -> bool:
    """``still_holds`` before the answer is judged, for sources taken as always fresh:
    the polled follower's row as the answer would leave it, its freshest update at
    ``tau`` and its p at ``p`` (its weight as it is)."""
    if now > pick.at + pick.slot or table.disturbed:
        return False
    i = pick.polled
    age = pick.at - max(table.tau[i], tau)
    value = pick.policy.indices([table.w[i]], [p], [age / pick.slot if age > 0.0 else 0.0])[0]
    return value < pick.value or (value == pick.value and i > pick.choice)


def _array_ages(table: PeerTable, taus: FloatArray, dues: FloatArray,
                intervals: FloatArray, readies: FloatArray, at: float,
                slot: float) -> FloatArray:
    """Ages in slots at ``at`` of the rows given (numpy), from the taus alone when every
    source is taken as always fresh."""
    if not (table.unfresh or table.known_intervals):
        return array_fresh_ages_in_slots(taus, at, slot)
    return array_ages_in_slots(taus, dues, intervals, readies, at, slot)


def _ages(table: PeerTable, at: float, slot: float) -> list[float]:
    """Every follower's age in slots at ``at`` (plain floats)."""
    if not (table.unfresh or table.known_intervals):
        return fresh_ages_in_slots(table.tau, at, slot)
    return ages_in_slots(table.tau, table.due, table.interval, table.ready, at, slot)
