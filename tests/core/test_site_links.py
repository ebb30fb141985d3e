"""Followers behind one link (a site, seen from the cloud) share its p: a dead wide-area
link silences the whole site within W polls of it, and its return revives them all."""

from __future__ import annotations

from wiswarm_zenoh.core import (
    Answering,
    Follower,
    Leader,
    LeaderConfig,
    Silent,
    TimedOut,
    drain,
)

from .drive import answer, poll

WINDOW = 4
SITES = {"s1.a": "s1", "s1.b": "s1", "s2.c": "s2"}


def _cloud() -> tuple[Leader, dict[str, Follower]]:
    leader = Leader(LeaderConfig(window=WINDOW, timeout=0.05, adaptive_timeout=False,
                                 pace_sources=False))  # they answer "nothing new" here
    for follower, site in SITES.items():
        leader.add_follower(follower, 0.0, link=site)
    return leader, {f: Follower(f) for f in SITES}


def test_a_dead_site_link_silences_the_site_and_its_return_revives_it() -> None:
    leader, followers = _cloud()
    now, silent, timeouts = 0.0, set(), {f: 0 for f in SITES}
    while any(leader.stats(f, now).polls == 0 for f in SITES):  # all answered: the link was up
        answer(leader, followers, poll(leader, now), now)
        now += 0.002
    drain(leader)
    while silent != {"s1.a", "s1.b"}:  # s1's link is down: its polls go unanswered
        request = poll(leader, now)
        if request.follower.startswith("s1."):
            leader.handle_timer(request.deadline)
            now = request.deadline
        else:
            answer(leader, followers, request, now)
            now += 0.002
        for event in drain(leader):
            if isinstance(event, Silent):
                silent.add(event.follower)
            elif isinstance(event, TimedOut):
                timeouts[event.follower] += 1
        assert now < 10.0, "the site never fell silent"
    # W timeouts of the site in all, shared between its followers: not W of each.
    assert timeouts["s1.a"] + timeouts["s1.b"] == WINDOW and timeouts["s2.c"] == 0
    assert leader.stats("s1.a", now).p_hat == leader.stats("s1.b", now).p_hat == 0.0
    assert leader.stats("s2.c", now).p_hat == 1.0
    back: set[str] = set()
    while back != {"s1.a", "s1.b"}:  # the link is back: the first probe answered
        request = poll(leader, now)
        events = answer(leader, followers, request, now)
        back |= {e.follower for e in events if isinstance(e, Answering)}
        now += 0.002
        assert now < 20.0, "the site never came back"
    assert leader.stats("s1.b", now).p_hat > 0.0


def test_a_site_p_leaves_with_its_last_follower_and_is_new_for_the_next() -> None:
    leader, _ = _cloud()
    for follower in ("s1.a", "s1.b"):
        leader.remove_follower(follower)
    leader.add_follower("s1.d", 1.0, link="s1")
    assert leader.stats("s1.d", 1.0).p_hat == 1.0  # the prior: no estimate carried over
    assert leader.stats("s1.a", 1.0).p_hat == 1.0  # the departed keep theirs
