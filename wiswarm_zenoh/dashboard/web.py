"""The web side: the page, its static files (uPlot, vendored) and the WebSocket.

A browser that connects gets a snapshot of the state, then every change; it sends
nothing. When it goes (closed tab, lost network), its sender ends and nothing else
notices; when it comes back it starts from a new snapshot.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import AsyncIterator
from importlib import resources
from pathlib import Path

from aiohttp import WSMsgType, web

from wiswarm_zenoh.dashboard.hub import Client, Hub
from wiswarm_zenoh.dashboard.state import SwarmState

log = logging.getLogger(__name__)

STATIC = Path(str(resources.files("wiswarm_zenoh.dashboard") / "static"))
HEARTBEAT_S = 10.0  # a browser that answers no ping for this long is gone
STATUS_PERIOD_S = 0.5  # how often browsers hear whether a leader is up
NO_CACHE = {"Cache-Control": "no-cache"}  # a new version of the page shows at once


def build_app(state: SwarmState, hub: Hub) -> web.Application:
    """The page at ``/``, its files under ``/static/``, the live feed at ``/ws``."""
    async def index(_request: web.Request) -> web.FileResponse:
        return web.FileResponse(STATIC / "index.html", headers=NO_CACHE)

    async def feed(request: web.Request) -> web.WebSocketResponse:
        ws = web.WebSocketResponse(heartbeat=HEARTBEAT_S)
        await ws.prepare(request)
        snapshot, since = state.snapshot()
        client = hub.join(snapshot, since)
        sender = asyncio.create_task(_send(ws, client))
        try:
            async for message in ws:  # the page sends nothing: this waits for it to go
                if message.type == WSMsgType.ERROR:
                    log.info("a browser's connection failed: %s", ws.exception())
        finally:
            hub.leave(client)
            sender.cancel()
        return ws

    async def status(_app: web.Application) -> AsyncIterator[None]:
        async def tick() -> None:
            while True:
                state.status()
                await asyncio.sleep(STATUS_PERIOD_S)
        task = asyncio.create_task(tick())
        yield
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task

    app = web.Application()
    app.router.add_get("/", index)
    app.router.add_get("/ws", feed)
    app.router.add_static("/static/", STATIC)
    app.cleanup_ctx.append(status)
    app.on_shutdown.append(lambda _app: _close_all(hub))
    return app


async def _close_all(hub: Hub) -> None:
    hub.close_all()


async def _send(ws: web.WebSocketResponse, client: Client) -> None:
    """Frames to one browser until it goes or is dropped (None)."""
    try:
        while (text := await client.queue.get()) is not None:
            await ws.send_str(text)
    except ConnectionError:  # it went while a frame was on its way
        return
    await ws.close()
