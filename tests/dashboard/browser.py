"""Headless Chromium driven over the Chrome DevTools Protocol, for tests and benchmarks.

The protocol is JSON over a WebSocket (aiohttp's client, already a dependency): this
module speaks the few commands needed (open a page, evaluate, screenshot) and keeps
what the page says on its console, so a test can see its errors. Calls are blocking:
the protocol's loop runs on a thread of its own.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import itertools
import json
import os
import re
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

import aiohttp

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
LISTENING = re.compile(r"DevTools listening on (ws://\S+)")
START_TIMEOUT = 30.0
CALL_TIMEOUT = 30.0


class BrowserError(Exception):
    """Chromium did not start, or a protocol call failed."""


class Browser:
    """One headless Chromium with one page; ``close()`` ends it."""

    def __init__(self, width: int = 1280, height: int = 1000) -> None:
        if CHROMIUM is None:
            raise BrowserError("chromium is not installed")
        self._profile = tempfile.TemporaryDirectory(prefix="wiswarm-chromium-")
        self._process = subprocess.Popen(
            [CHROMIUM, "--headless=new", "--no-sandbox",
             "--disable-dev-shm-usage", "--no-first-run", "--no-default-browser-check",
             "--remote-debugging-port=0", f"--user-data-dir={self._profile.name}",
             f"--window-size={width},{height}", "about:blank"],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
            text=True, start_new_session=True)  # its helpers in its group: ended with it
        self.errors: list[str] = []  # console errors, exceptions, failed loads of the page
        self._ids = itertools.count(1)
        self._replies: dict[int, asyncio.Future[dict[str, Any]]] = {}
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, daemon=True)
        self._thread.start()
        try:
            self._call(self._connect(self._endpoint()))
        except BaseException:
            self.close()
            raise

    def _endpoint(self) -> str:
        assert self._process.stderr is not None
        deadline = time.monotonic() + START_TIMEOUT
        while time.monotonic() < deadline:
            line = self._process.stderr.readline()
            if not line and self._process.poll() is not None:
                break
            found = LISTENING.search(line)
            if found:
                threading.Thread(target=self._process.stderr.read, daemon=True).start()
                return found.group(1)
        raise BrowserError("chromium did not start its DevTools endpoint")

    def _call(self, coroutine: Any) -> Any:
        future: Future[Any] = asyncio.run_coroutine_threadsafe(coroutine, self._loop)
        return future.result(CALL_TIMEOUT)

    async def _connect(self, endpoint: str) -> None:
        self._http = aiohttp.ClientSession()
        self._ws = await self._http.ws_connect(endpoint, max_msg_size=0)
        self._reader = asyncio.create_task(self._read())
        target = await self._send("Target.createTarget", {"url": "about:blank"})
        attached = await self._send("Target.attachToTarget",
                                    {"targetId": target["targetId"], "flatten": True})
        self._session = attached["sessionId"]
        for domain in ("Page", "Runtime", "Log"):
            await self._send(f"{domain}.enable", session=True)

    async def _read(self) -> None:
        async for message in self._ws:
            data = json.loads(message.data)
            if "id" in data and data["id"] in self._replies:
                self._replies.pop(data["id"]).set_result(data)
            else:
                self._event(data.get("method", ""), data.get("params", {}))

    def _event(self, method: str, params: dict[str, Any]) -> None:
        if method == "Runtime.consoleAPICalled" and params["type"] in ("error", "assert"):
            self.errors.append(" ".join(str(a.get("value", a.get("description", "")))
                                        for a in params["args"]))
        elif method == "Runtime.exceptionThrown":
            details = params["exceptionDetails"]
            self.errors.append(details.get("exception", {}).get("description",
                                                                details.get("text", "")))
        elif method == "Log.entryAdded" and params["entry"]["level"] == "error":
            self.errors.append(f"{params['entry']['text']} {params['entry'].get('url', '')}")

    async def _send(self, method: str, params: dict[str, Any] | None = None,
                    session: bool = False) -> dict[str, Any]:
        number = next(self._ids)
        message: dict[str, Any] = {"id": number, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = self._session
        reply: asyncio.Future[dict[str, Any]] = self._loop.create_future()
        self._replies[number] = reply
        await self._ws.send_str(json.dumps(message))
        data = await reply
        if "error" in data:
            raise BrowserError(f"{method}: {data['error']}")
        result: dict[str, Any] = data["result"]
        return result

    def command(self, method: str, params: dict[str, Any] | None = None) -> dict[str, Any]:
        """A command to the page (``Page.navigate``, ``Runtime.evaluate``...)."""
        result: dict[str, Any] = self._call(self._send(method, params, session=True))
        return result

    def open(self, url: str) -> None:
        self.command("Page.navigate", {"url": url})

    def evaluate(self, expression: str) -> Any:
        """The value of a JavaScript expression in the page (JSON-able)."""
        result = self.command("Runtime.evaluate", {"expression": expression,
                                                   "returnByValue": True})
        if "exceptionDetails" in result:
            raise BrowserError(f"{expression}: {result['exceptionDetails']}")
        return result["result"].get("value")

    def wait_for(self, what: str, expression: str, timeout: float = 15.0,
                 accept: Callable[[Any], bool] = bool) -> Any:
        """Poll ``expression`` until ``accept`` takes its value (a deadline, not a sleep
        in place of an event: the page's state is only seen by asking)."""
        deadline = time.monotonic() + timeout
        while True:
            value = self.evaluate(expression)
            if accept(value):
                return value
            if time.monotonic() > deadline:
                raise BrowserError(f"timed out waiting for {what}: last {value!r}")
            time.sleep(0.05)

    def screenshot(self, clip: dict[str, float] | None = None) -> bytes:
        """A PNG of the page (of ``clip``: x, y, width, height in CSS pixels)."""
        params: dict[str, Any] = {"format": "png"}
        if clip is not None:
            params["clip"] = {**clip, "scale": 1}
        return base64.b64decode(self.command("Page.captureScreenshot", params)["data"])

    def close(self) -> None:
        if hasattr(self, "_ws"):
            self._call(self._disconnect())
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join()
        self._loop.close()
        self._process.terminate()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self._process.wait(10)
        # Its renderer, GPU and crash-handler processes outlive it a moment and still
        # write into the profile: removing it then failed ("Directory not empty"). Killed
        # with the group, none writes again.
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self._process.pid, signal.SIGKILL)
        self._process.wait()
        self._profile.cleanup()

    async def _disconnect(self) -> None:
        await self._ws.close()
        self._reader.cancel()
        await self._http.close()
