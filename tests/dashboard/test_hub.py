"""The fan-out to browsers: each message once, after the snapshot that holds those
before it; a browser that stops reading is dropped, never waited for."""

from __future__ import annotations

import asyncio
import json
import math

from wiswarm_zenoh.dashboard.hub import QUEUE_FRAMES, Client, Hub, to_text


def frames(client: Client) -> list[object]:
    out: list[object] = []
    while not client.queue.empty():
        text = client.queue.get_nowait()
        out.append(None if text is None else json.loads(text))
    return out


def test_a_new_browser_gets_what_its_snapshot_lacks_and_no_more() -> None:
    async def run() -> None:
        hub = Hub(asyncio.get_running_loop())
        old = hub.join({"type": "snapshot", "n": 0}, 0)
        for n in (1, 2, 3):
            hub.publish({"type": "status", "n": n})
        new = hub.join({"type": "snapshot", "n": 2}, 2)  # it holds messages 1 and 2
        await asyncio.sleep(0)  # the loop sends what was published, in one frame each
        assert frames(old) == [[{"type": "snapshot", "n": 0}],
                               [{"type": "status", "n": n} for n in (1, 2, 3)]]
        assert frames(new) == [[{"type": "snapshot", "n": 2}], [{"type": "status", "n": 3}]]

    asyncio.run(run())


def test_a_browser_that_stops_reading_is_dropped() -> None:
    async def run() -> None:
        hub = Hub(asyncio.get_running_loop())
        stalled = hub.join({"type": "snapshot"}, 0)
        for n in range(QUEUE_FRAMES + 5):
            hub.publish({"type": "status", "n": n})
            await asyncio.sleep(0)  # each its own frame
        assert hub.dropped == 1
        assert frames(stalled) == [None]  # its sender ends, closing the socket
        hub.publish({"type": "status"})  # the others go on
        await asyncio.sleep(0)
        assert frames(stalled) == []

    asyncio.run(run())


def test_numbers_the_browser_cannot_read_go_as_null() -> None:
    assert json.loads(to_text([{"age": math.inf, "list": [math.nan, 1.0]}])) == [
        {"age": None, "list": [None, 1.0]}]
