"""``SwarmRecording``: a running swarm's channels (``channels``) into an MCAP file
(``wiswarm record``, ``wiswarm demo``'s ``run.mcap``) and/or live to Foxglove through the
SDK's WebSocket server (``wiswarm foxglove``). It only subscribes: the leader sends its
delivery stream and fresh updates only while someone listens, and a put never waits.
The Foxglove SDK (the foxglove extra) is loaded when a recording is made, not with this
package."""

from __future__ import annotations

import contextlib
import logging
from pathlib import Path
from types import TracebackType

import zenoh

from wiswarm_zenoh.extras import require
from wiswarm_zenoh.ros2 import UpdateAdapter
from wiswarm_zenoh.transport.watch import Watch

log = logging.getLogger(__name__)

DEFAULT_PORT = 8765  # Foxglove's own default
DEFAULT_HOST = "127.0.0.1"


class SwarmRecording:
    """Records ``swarm`` into ``mcap`` (a path) and/or serves it on ``host:port`` (port 0:
    any free one; ``url`` says where) until ``close()``. ``adapter`` makes images and
    poses of the fresh updates (without one, updates are not subscribed to).
    MissingExtra without the foxglove extra."""

    def __init__(self, session: zenoh.Session, swarm: str, *, mcap: Path | None = None,
                 port: int | None = None, host: str = DEFAULT_HOST,
                 adapter: UpdateAdapter | None = None) -> None:
        require("foxglove")
        import foxglove

        from wiswarm_zenoh.recording.channels import SwarmChannels

        self._context = foxglove.Context()
        self.channels = SwarmChannels(self._context, swarm, adapter)
        self._sinks = contextlib.ExitStack()
        self.url: str | None = None
        try:
            if mcap is not None:
                writer = foxglove.open_mcap(mcap, allow_overwrite=True, context=self._context)
                self._sinks.callback(writer.close)
            if port is not None:
                server = foxglove.start_server(name=f"wiswarm {swarm}", host=host, port=port,
                                               context=self._context)
                self._sinks.callback(server.stop)
                self.url = f"ws://{host}:{server.port}"
            self._watch = Watch(session, self.channels.handlers(), self.channels.bad_input,
                                self.channels.liveliness())
        except BaseException:
            self._sinks.close()
            raise
        log.info("recording swarm %s%s%s", swarm, f" into {mcap}" if mcap else "",
                 f", live on {self.url}" if self.url else "")

    def close(self) -> None:
        """Stop listening, then finish the file (its summary and index) and the server."""
        self._watch.close()
        self._sinks.close()

    def __enter__(self) -> SwarmRecording:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
