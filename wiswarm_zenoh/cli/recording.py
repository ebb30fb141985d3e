"""``wiswarm record`` and ``wiswarm foxglove``: a running swarm in Foxglove, recorded to
MCAP or served live, from its key expressions only (``wiswarm_zenoh.recording``;
commands that watch: ``watching``)."""

from __future__ import annotations

import argparse
import threading
from typing import Any

from wiswarm_zenoh.cli.watching import add_serve_arguments, add_watch_arguments, watch_spec
from wiswarm_zenoh.options import UPDATE_ADAPTER, UsageError, writable_file
from wiswarm_zenoh.programs.runners import wait_until_stopped
from wiswarm_zenoh.recording import DEFAULT_HOST, DEFAULT_PORT, SwarmRecording
from wiswarm_zenoh.ros2 import adapter
from wiswarm_zenoh.transport.zenoh_config import SessionSpec


def run_recording(spec: SessionSpec, args: argparse.Namespace, title: str,
                  **sinks: Any) -> int:
    """Record or serve until Ctrl-C or ``--duration``; say what went where."""
    updates = None if args.updates is None else adapter(args.updates)
    with spec.open() as session:
        try:
            recording = SwarmRecording(session, args.swarm, adapter=updates, **sinks)
        except (OSError, RuntimeError) as exc:  # the file or the port
            raise UsageError(f"cannot {title}: {exc}") from None
        try:
            where = recording.url or sinks.get("mcap")
            print(f"wiswarm {title}: swarm {args.swarm!r} on {where} (Ctrl-C to stop)",
                  flush=True)
            wait_until_stopped(threading.Event(), args.duration)
        finally:
            recording.close()
    counts = recording.channels.counts
    print(f"{sum(counts.values())} messages on {len(counts)} channels", flush=True)
    return 0


def _record(args: argparse.Namespace) -> int:
    return run_recording(watch_spec(args), args, "record", mcap=args.out)


def _foxglove(args: argparse.Namespace) -> int:
    return run_recording(watch_spec(args), args, "foxglove", port=args.port, host=args.host)


def _add_common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--updates", metavar="ADAPTER", type=UPDATE_ADAPTER,
                        help="also take each delivered update (wiswarm/<swarm>/<id>/fresh) "
                        "through this application's adapter into images and poses (tracking: "
                        "the demo's frames); by default updates are not subscribed to")
    add_watch_arguments(parser, "the swarm")


DESCRIPTION = ("Channels, under /wiswarm/<swarm>: deliveries (every delivery and unanswered "
               "poll), <follower>/stats, leader/stats, control, <uav>/tracking (JSON with "
               "JSON schemas), arena (foxglove.SceneUpdate), log (foxglove.Log: followers and "
               "leaders coming and going); with --updates, <follower>/image "
               "(foxglove.CompressedImage, PNG) and <follower>/pose (foxglove.PoseInFrame).")


def register(subparsers: Any) -> None:
    record = subparsers.add_parser(
        "record", help="record a running swarm to an MCAP file (opens in Foxglove)",
        description="Records a running swarm, from its key expressions, to an MCAP file "
        "with Foxglove's schemas. " + DESCRIPTION)
    record.add_argument("-o", "--out", required=True, type=writable_file(), metavar="FILE.mcap",
                        help="the MCAP file to write (replaced if it exists)")
    _add_common(record)
    record.set_defaults(func=_record, needs="foxglove")

    live = subparsers.add_parser(
        "foxglove", help="serve a running swarm live to the Foxglove app (WebSocket)",
        description="Serves a running swarm live through the Foxglove SDK's WebSocket "
        "server: in Foxglove, open a connection to the address it prints. " + DESCRIPTION)
    add_serve_arguments(live, "the WebSocket", DEFAULT_PORT, DEFAULT_HOST, any_port=True)
    _add_common(live)
    live.set_defaults(func=_foxglove, needs="foxglove")
