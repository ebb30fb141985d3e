"""``Dashboard``: the whole dashboard on a thread of its own, for ``wiswarm dashboard``
and for any program that wants one beside its swarm (the tracking demo).

The web server runs an asyncio loop on that thread; the Zenoh subscribers run on Zenoh's
threads and hand their changes to it. ``close()`` stops both; ``finish()`` stops the
subscribers only, so that a run that has ended stays on view after its session closes.
The server (aiohttp, the dashboard extra) is loaded when a dashboard is made, not with
this package, whose live points and feed the experiments use without it.
"""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import logging
import threading
from types import TracebackType

import zenoh

from wiswarm_zenoh.dashboard.feed import Feed
from wiswarm_zenoh.dashboard.hub import Hub
from wiswarm_zenoh.dashboard.state import WINDOW_S, SwarmState
from wiswarm_zenoh.extras import require
from wiswarm_zenoh.transport.zenoh_config import SessionSpec

log = logging.getLogger(__name__)

DEFAULT_PORT = 8050
DEFAULT_HOST = "127.0.0.1"  # this machine only; 0.0.0.0 or :: to serve other machines
SHUTDOWN_S = 2.0  # the longest ``close()`` waits for browsers to say goodbye


def _url(host: str, port: int) -> str:
    """Where a browser on this machine finds the page (an unspecified address serves
    every interface, loopback included)."""
    address = ipaddress.ip_address(host)
    if address.is_unspecified:
        address = ipaddress.ip_address("::1" if address.version == 6 else "127.0.0.1")
    shown = f"[{address}]" if address.version == 6 else str(address)
    return f"http://{shown}:{port}/"


class Dashboard:
    """Serves the live page of ``swarm`` on ``host:port`` (port 0: any free one) until
    ``close()``; ``url`` says where. Raises OSError if it cannot listen there, and
    MissingExtra without the dashboard extra."""

    def __init__(self, session: zenoh.Session, swarm: str, port: int = DEFAULT_PORT,
                 host: str = DEFAULT_HOST, *, window_s: float = WINDOW_S) -> None:
        require("dashboard")
        from aiohttp import web

        from wiswarm_zenoh.dashboard.web import build_app

        self._loop = asyncio.new_event_loop()
        self.hub = Hub(self._loop)
        self.state = SwarmState(swarm, self.hub.publish, window_s=window_s)
        self._owned = contextlib.ExitStack()  # a session that ``open`` made: closed last
        self._runner = web.AppRunner(build_app(self.state, self.hub), handle_signals=False,
                                     shutdown_timeout=SHUTDOWN_S, access_log=None)
        started = threading.Event()
        self._error: OSError | None = None
        self._thread = threading.Thread(target=self._serve, args=(host, port, started),
                                        name=f"dashboard-{swarm}", daemon=True)
        self._thread.start()
        started.wait()
        if self._error is not None:
            self._thread.join()
            raise self._error
        self.url = _url(host, self._runner.addresses[0][1])
        self._listening = contextlib.ExitStack()  # the subscribers: until finish or close
        try:
            self._listening.callback(Feed(session, self.state).close)
        except BaseException:
            self._stop_server()
            raise
        log.info("dashboard of swarm %s on %s", swarm, self.url)

    @classmethod
    def open(cls, spec: SessionSpec, swarm: str, port: int = DEFAULT_PORT,
             host: str = DEFAULT_HOST) -> Dashboard:
        """A dashboard with a session of its own (closed by ``close()``)."""
        with contextlib.ExitStack() as stack:
            dashboard = cls(stack.enter_context(spec.open()), swarm, port, host)
            dashboard._owned = stack.pop_all()
        return dashboard

    def _serve(self, host: str, port: int, started: threading.Event) -> None:
        from aiohttp import web  # loaded by __init__

        asyncio.set_event_loop(self._loop)
        try:
            self._loop.run_until_complete(self._runner.setup())
            self._loop.run_until_complete(web.TCPSite(self._runner, host, port).start())
        except OSError as exc:
            self._error = exc
            self._loop.run_until_complete(self._runner.cleanup())
            self._loop.close()
            return
        finally:
            started.set()
        try:
            self._loop.run_forever()
        finally:
            self._loop.run_until_complete(self._runner.cleanup())
            self._loop.close()

    def finish(self) -> None:
        """Stop the subscribers and go on serving what they brought, marked finished,
        until ``close()``: the session may close, the page still shows the run's end."""
        self._listening.close()
        self.state.finish()

    def close(self) -> None:
        """Stop the subscribers, then the server (the browsers are told it went)."""
        self._listening.close()
        self._stop_server()
        self._owned.close()

    def _stop_server(self) -> None:
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join()

    def __enter__(self) -> Dashboard:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
