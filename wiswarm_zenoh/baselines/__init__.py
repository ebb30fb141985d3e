"""The baselines a Zenoh user would pick instead of polling: frames pushed at a fixed
rate over Zenoh ``put`` (reliable or best effort), plain UDP or plain TCP, and the
receivers that measure them as the polling leader measures its deliveries."""

from wiswarm_zenoh.baselines.receivers import Receiver
from wiswarm_zenoh.baselines.runners import (
    BaselineFollowerOptions,
    ReceiverOptions,
    run_baseline_followers,
    run_receiver,
)
from wiswarm_zenoh.baselines.senders import PushSender, TcpSender, UdpSender

__all__ = [
    "BaselineFollowerOptions",
    "PushSender",
    "Receiver",
    "ReceiverOptions",
    "TcpSender",
    "UdpSender",
    "run_baseline_followers",
    "run_receiver",
]
