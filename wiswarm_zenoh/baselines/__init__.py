"""The baselines a Zenoh user would pick instead of polling: frames pushed at a fixed
rate into a FIFO and sent over Zenoh ``put`` (block: reliable, the paper's WiFi-TCP;
drop: Zenoh's default), plain UDP or plain TCP (the paper's WiFi-UDP and WiFi-TCP), or
newest only (each robot's newest frame, sent once the previous send completed: over a
blocking put or TCP), and the receivers that measure them as the polling leader
measures its deliveries."""

from wiswarm_zenoh.baselines.fifo import DEFAULT_CAPACITY, FrameFifo, FramePump
from wiswarm_zenoh.baselines.newest import NEWEST_SEND_BUFFER, NewestPump, NewestSlot
from wiswarm_zenoh.baselines.receivers import SYSTEMS, Receiver
from wiswarm_zenoh.baselines.runners import (
    BaselineFollowerOptions,
    ReceiverOptions,
    run_baseline_followers,
    run_receiver,
)
from wiswarm_zenoh.baselines.senders import (
    CONGESTION,
    NEWEST_ZENOH,
    PushSender,
    QueuedSender,
    TcpSender,
    UdpSender,
)
from wiswarm_zenoh.baselines.servers import DEFAULT_BIND

__all__ = [
    "CONGESTION",
    "DEFAULT_BIND",
    "DEFAULT_CAPACITY",
    "NEWEST_SEND_BUFFER",
    "NEWEST_ZENOH",
    "SYSTEMS",
    "BaselineFollowerOptions",
    "FrameFifo",
    "FramePump",
    "NewestPump",
    "NewestSlot",
    "PushSender",
    "QueuedSender",
    "Receiver",
    "ReceiverOptions",
    "TcpSender",
    "UdpSender",
    "run_baseline_followers",
    "run_receiver",
]
