"""A slot per key that keeps only the newest value, for a consumer slower than its
producer: an AoI middleware hands it the freshest update of each source, never a queue
of stale ones. A value put over one not yet taken replaces it (and is given back, to
count); the consumer takes the keys in the order they began to wait, which is round
robin while all are busy."""

from __future__ import annotations

import threading
from collections.abc import Hashable
from typing import Generic, TypeVar

K = TypeVar("K", bound=Hashable)
V = TypeVar("V")


class Freshest(Generic[K, V]):
    """Thread-safe: any threads put, one takes, until ``close()``."""

    def __init__(self) -> None:
        self._waiting: dict[K, V] = {}  # in the order the keys began to wait
        self._cond = threading.Condition()
        self._closed = False

    def put(self, key: K, value: V) -> V | None:
        """Leave ``value`` for ``key``; the value it replaced, not taken yet, or None."""
        with self._cond:
            replaced = self._waiting.get(key)
            self._waiting[key] = value  # a key waiting keeps its turn
            self._cond.notify()
        return replaced

    def take(self) -> tuple[K, V] | None:
        """The key that has waited longest and its value, waiting for one; None once
        closed (what waits then is dropped)."""
        with self._cond:
            self._cond.wait_for(lambda: self._waiting or self._closed)
            if self._closed:
                return None
            key = next(iter(self._waiting))
            return key, self._waiting.pop(key)

    def close(self) -> None:
        """Wake the consumer: ``take`` returns None from now on."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
