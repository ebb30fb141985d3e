"""``wiswarm follower``: answer a swarm's polls with synthetic frames or what the robot
already publishes (``--system wiswarm``), or push them as a baseline would
(``--system push|udp|tcp``, ``--newest-only``)."""

from __future__ import annotations

import argparse
import threading
from typing import Any

from wiswarm_zenoh.baselines import (
    CONGESTION,
    DEFAULT_CAPACITY,
    NEWEST_SEND_BUFFER,
    BaselineFollowerOptions,
    run_baseline_followers,
)
from wiswarm_zenoh.cli.node_flags import (
    SYSTEMS,
    Announce,
    add_common,
    add_swarm,
    check_frame_bytes,
    checked,
    given,
    only_for,
    session_spec,
)
from wiswarm_zenoh.core import FollowerConfig
from wiswarm_zenoh.extras import require
from wiswarm_zenoh.options import (
    UsageError,
    add_source_arguments,
    host_port,
    node_name,
    one_source,
    positive_float,
    positive_int,
    streams_of,
)
from wiswarm_zenoh.programs.frames import FRAME_BYTES, FRAME_RATE
from wiswarm_zenoh.programs.runners import FollowerOptions, run_follower
from wiswarm_zenoh.programs.ticker import MAX_RATE_HZ
from wiswarm_zenoh.ros2.newest_push import republished_topic
from wiswarm_zenoh.ros2.topic_source import Ros2TopicSource
from wiswarm_zenoh.security.checks import check_identity

BASELINE_RATE = 50.0  # frames/s: the paper's fixed-rate baselines
FOLLOWER_ONLY = {"queue": ("wiswarm",), "fragment_size": ("wiswarm",),
                 "congestion": ("push",), "to": ("udp", "tcp"), "source": ("wiswarm",),
                 "ros2_topic": ("wiswarm", "push"), "ros2_waypoints": ("wiswarm",),
                 "newest_only": ("push", "tcp"), "send_buffer": ("tcp",)}


def _check_newest_only(args: argparse.Namespace) -> None:
    """Flags that --newest-only excludes, or needs."""
    if args.newest_only:
        if args.congestion == "drop":
            raise UsageError("--newest-only sends each frame once the previous put "
                             "completed: it needs --congestion block (the default), not drop")
        if args.capacity is not None:
            raise UsageError("--capacity sizes the FIFO: --newest-only keeps one frame, "
                             "the newest")
    elif args.send_buffer is not None:
        raise UsageError("--send-buffer is for --newest-only")
    elif args.ros2_topic is not None:
        raise UsageError("--ros2-topic with --system push needs --newest-only")


def _baseline_follower(args: argparse.Namespace) -> int:
    """``wiswarm follower --system push|udp|tcp``: frames pushed at ``--rate`` (newest
    only: each once the previous send completed), or the robot's ROS 2 topic."""
    if args.system != "push" and args.to is None:
        raise UsageError(f"--system {args.system} needs --to HOST:PORT (where "
                         f"wiswarm leader --system {args.system} listens)")
    _check_newest_only(args)
    source = one_source(args, f"--system {args.system} pushes one stream")
    if source is not None and not isinstance(source, Ros2TopicSource):
        raise UsageError("--source is for --system wiswarm")  # flags checked: never here
    newest = bool(args.newest_only)
    options = checked(BaselineFollowerOptions, args.swarm, (args.id,), args.system,
                      args.rate or (FRAME_RATE if newest else BASELINE_RATE),
                      args.congestion or "block", args.frame_bytes, args.to,
                      args.capacity or DEFAULT_CAPACITY, args.duration, newest,
                      args.send_buffer or NEWEST_SEND_BUFFER, source)
    spec = session_spec(args, "peer")
    how = f"{options.congestion} put" if args.system == "push" else f"to {args.to}"
    what = f"{args.frame_bytes}-byte frames at {options.rate:g} Hz"
    if source is not None:
        what = f"the samples of {source.topic}"
        how += f" on {republished_topic(args.swarm, args.id, source.topic)}"
    queue = f" into a FIFO of {options.capacity}"
    if newest:
        queue = ", newest only" + (f", send buffer {options.send_buffer} B"
                                   if args.system == "tcp" else "")
    run_baseline_followers(spec, options, threading.Event(), Announce(
        f"wiswarm follower {args.id}: {what}{queue}, {args.system} ({how}) (Ctrl-C to "
        "stop)"))
    return 0


def _follower(args: argparse.Namespace) -> int:
    check_identity(args.config, args.id)
    only_for(args, FOLLOWER_ONLY)
    if args.system != "wiswarm":
        return _baseline_follower(args)
    rate = args.rate or FRAME_RATE
    config = checked(FollowerConfig, **given(args, "queue", "capacity", "fragment_size"),
                     rate_hz=rate if args.queue == "fifo" else None)
    check_frame_bytes(args.frame_bytes, config)
    streams = streams_of(args)
    if args.ros2_waypoints is not None:
        require("ros2")  # the Path is made and serialized here
    options = FollowerOptions(args.swarm, args.id, config, args.frame_bytes, rate,
                              args.duration, streams, args.ros2_waypoints, args.ros_domain or 0)
    spec = session_spec(args, "peer")
    what = (f"{args.frame_bytes}-byte frames at {rate:g} Hz" if not streams else
            "; ".join(f"the samples of {s.what}" + ("" if s.member == args.id else
                                                     f" as {s.member}") for s in streams))
    run_follower(spec, options, threading.Event(), Announce(
        f"wiswarm follower {args.id}: {what}, {config.queue} queue (Ctrl-C to stop)"))
    return 0


def register_follower(subparsers: Any) -> None:
    follower = subparsers.add_parser(
        "follower", help="a follower sending synthetic frames, or what the robot publishes",
        description="A follower taking synthetic frames at --rate, or the samples the "
        "robot already publishes (--source KEYEXPR, --ros2-topic TOPIC). --system wiswarm (the "
        "default) queues them (LIFO: the freshest only) and answers the leader's polls; "
        "push, udp and tcp are the baselines: every frame is stamped into a FIFO of "
        f"--capacity frames (default {DEFAULT_CAPACITY}; a full FIFO drops the new frame) "
        "and sent in order, by Zenoh put (push) or plain sockets to --to (udp: one "
        "datagram a frame; tcp: one connection). push and tcp --newest-only keep only the "
        "newest frame instead and send it the moment the previous send completed.")
    add_swarm(follower)
    follower.add_argument("--id", required=True, type=node_name("follower id", robot=True),
                          help="this follower's id (a key chunk)")
    follower.add_argument("--system", choices=SYSTEMS, default="wiswarm",
                          help="wiswarm: answer polls (default); push: put every frame on "
                          "wiswarm/<swarm>/<id>/push; udp/tcp: send every frame to --to")
    follower.add_argument("--newest-only", action="store_true", default=None,
                          help="push/tcp: keep only the newest frame (a newer one replaces "
                          "it, an older one never does) and send it the moment the previous "
                          "send completed: the rate adapts to the path, nothing to tune "
                          f"(--rate is the camera's, default {FRAME_RATE:g}). push: the put "
                          "blocks (congestion block), over one batch of Zenoh tx queue and "
                          f"a {NEWEST_SEND_BUFFER}-byte TCP send buffer (--cfg overrides); "
                          "with --ros2-topic TOPIC, the robot's samples go as they came, as "
                          "a ROS 2 topic where a WiSwarm leader's --ros2 republishes it: "
                          "/wiswarm/<swarm>/<id>TOPIC")
    follower.add_argument("--send-buffer", type=positive_int(), metavar="BYTES",
                          help="tcp --newest-only: the socket's SO_SNDBUF (default "
                          f"{NEWEST_SEND_BUFFER}; the kernel doubles it), small so that a "
                          "frame waits in the slot, where a newer one replaces it, not in "
                          "the kernel")
    follower.add_argument("--congestion", choices=sorted(CONGESTION),
                          help="push: block (reliable, the put waits while Zenoh's queues "
                          "are full: the paper's WiFi-TCP; default) or drop (a plain put: "
                          "Zenoh's default)")
    follower.add_argument("--to", metavar="HOST:PORT", type=host_port(),
                          help="udp/tcp: the receiver (wiswarm leader --system udp|tcp)")
    follower.add_argument("--queue", choices=["lifo", "fifo"],
                          help="wiswarm: the follower's queue (default lifo)")
    follower.add_argument("--capacity", type=positive_int(),
                          help=f"queue capacity (default 1; push/udp/tcp: a FIFO of "
                          f"{DEFAULT_CAPACITY}; not with --newest-only)")
    follower.add_argument("--rate", type=positive_float(MAX_RATE_HZ),
                          help=f"frames per second (default {FRAME_RATE:g}; push/udp/tcp: "
                          f"{BASELINE_RATE:g}, the paper's, but {FRAME_RATE:g} with "
                          "--newest-only), and a wiswarm FIFO's rate control")
    follower.add_argument("--fragment-size", type=positive_int(),
                          help="wiswarm: bytes per reply (default "
                          f"{FollowerConfig().fragment_size})")
    follower.add_argument("--frame-bytes", type=positive_int(), default=FRAME_BYTES,
                          help=f"bytes per synthetic frame (default {FRAME_BYTES} = 224x224; "
                          "udp: what fits one datagram)")
    add_source_arguments(follower)
    add_common(follower, ("peer", "client"))
    follower.set_defaults(func=_follower)
