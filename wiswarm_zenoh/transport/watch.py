"""Subscriptions to a swarm's keys for tools that only watch (the ``Observer``, the
dashboard, the MCAP recorder, the Foxglove server): anyone may publish on those keys, so
each handler's ValueError or WireError is bad input, counted and logged with the
sample's key. Liveliness tokens are followed by ``discovery`` (asked again for what
Zenoh's first answer missed)."""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from contextlib import ExitStack
from typing import Any

import zenoh

from wiswarm_zenoh.core import WireError
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.discovery import Discovery

Handler = Callable[[str, zenoh.Sample], None]
TokenHandler = Callable[[str, bool], None]  # a token's key, and whether it came or went


def loads(payload: bytes) -> Any:
    """JSON from bytes; ValueError (with the decoder's words) for anything else."""
    try:
        return json.loads(payload)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"not JSON: {exc}") from None


def json_payload(handler: Callable[[str, Any], None]) -> Handler:
    """A handler of the sample's JSON (bytes that are not JSON: ValueError)."""
    def on_sample(key: str, sample: zenoh.Sample) -> None:
        handler(key, loads(sample.payload.to_bytes()))
    return on_sample


class Watch:
    """One subscriber per key expression of ``handlers``, and one ``Discovery`` per key
    expression of ``liveliness``, on ``session`` until ``close()``; handlers run on
    Zenoh's threads."""

    def __init__(self, session: zenoh.Session, handlers: Mapping[str, Handler],
                 bad_input: BadInputLog, liveliness: Mapping[str, TokenHandler] | None = None
                 ) -> None:
        self._session = session  # held: a session nobody references is closed
        self._bad_input = bad_input
        self._entities = ExitStack()
        try:
            for key_expr, handler in handlers.items():
                self._entities.enter_context(session.declare_subscriber(
                    key_expr, self._guarded(handler)))
            for key_expr, on_token in (liveliness or {}).items():
                discovery = Discovery(session, key_expr, self._guarded_token(on_token),
                                      "liveliness token")
                self._entities.callback(discovery.close)
        except BaseException:
            self._entities.close()
            raise

    def _guarded(self, handler: Handler) -> Callable[[zenoh.Sample], None]:
        def on_sample(sample: zenoh.Sample) -> None:
            key = str(sample.key_expr)
            try:
                handler(key, sample)
            except (ValueError, WireError) as exc:
                self._bad_input.report(key, str(exc))
        return on_sample

    def _guarded_token(self, handler: TokenHandler) -> TokenHandler:
        def on_token(key: str, alive: bool) -> None:
            try:
                handler(key, alive)
            except ValueError as exc:
                self._bad_input.report(key, str(exc))
        return on_token

    def close(self) -> None:
        self._entities.close()
