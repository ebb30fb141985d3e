"""Members that never give a valid answer, as they happen in the field, for the tests
and benchmarks that show they cost the swarm almost nothing: a liveliness token with
no queryable (a follower that crashed after declaring it, or anyone on an open swarm),
a queryable that never replies (a hung process), one that replies garbage, and a churn
of hung ones under a new name every ``period`` seconds."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager

import zenoh

from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys

GARBAGE = b"\xc1 not msgpack at all"


@contextmanager
def token_only(session: zenoh.Session, keys: SwarmKeys, name: str = "ghost") -> Iterator[None]:
    token = session.liveliness().declare_token(keys.member(name))
    try:
        yield
    finally:
        undeclare(token)


@contextmanager
def hung(session: zenoh.Session, keys: SwarmKeys, name: str = "ghost") -> Iterator[None]:
    held: list[zenoh.Query] = []  # never answered, never dropped: no final either
    queryable = session.declare_queryable(keys.update(name), held.append)
    try:
        with token_only(session, keys, name):
            yield
    finally:
        undeclare(queryable)
        held.clear()


@contextmanager
def garbage(session: zenoh.Session, keys: SwarmKeys, name: str = "ghost") -> Iterator[None]:
    def on_query(query: zenoh.Query) -> None:
        with query:
            query.reply(keys.update(name), GARBAGE)

    queryable = session.declare_queryable(keys.update(name), on_query)
    try:
        with token_only(session, keys, name):
            yield
    finally:
        undeclare(queryable)


@contextmanager
def churn(session: zenoh.Session, keys: SwarmKeys, period: float = 1.0) -> Iterator[None]:
    """A hung member under a new name (``ghost0``, ``ghost1``, ...) every ``period`` s."""
    stop = threading.Event()

    def run() -> None:
        k = 0
        while not stop.is_set():
            with hung(session, keys, f"ghost{k}"):
                stop.wait(period)
            k += 1

    thread = threading.Thread(target=run, name="churn")
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()


Rogue = Callable[[zenoh.Session, SwarmKeys], AbstractContextManager[None]]
KINDS: dict[str, Rogue] = {"token only": token_only, "hung queryable": hung,
                           "garbage": garbage, "churn": churn}
