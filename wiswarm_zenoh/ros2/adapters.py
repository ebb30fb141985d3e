"""How an application's updates become standard ROS 2 messages: an adapter it gives
the leader (``Ros2Options.adapter``), or names for the command line
(``wiswarm leader --ros2 --ros-updates NAME``). Without one, each update goes out as
its bytes (``std_msgs/msg/UInt8MultiArray`` on ``<ns>/<follower>/update``).

The command line finds an adapter by name among the installed packages' entry points
of the group ``wiswarm_zenoh.update_adapters`` (``NAME = "package.module:Adapter"``, an
adapter or a class made with no argument; this project's ``tracking`` is one), so a
package of the application's own adds one with no change here; in a process of its
own, ``register_adapter`` does the same."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Any, Protocol

import numpy as np

from wiswarm_zenoh.ros2.messages import UPDATE_BYTES, message_class, ros_type


@dataclass(frozen=True)
class Output:
    """One message an adapter makes of each update: on ``<ns>/<follower>/<leaf>``."""

    leaf: str
    type_name: str

    def __post_init__(self) -> None:
        ros_type(self.type_name)


class UpdateAdapter(Protocol):
    """Maps one delivered update to one message per output (in order), stamped
    ``generated_at`` (the update's generation time, leader clock, s) where the type has a
    header. Raises ValueError or WireError for an update it cannot map (counted and
    logged with the follower's key, as bad input from it)."""

    @property
    def outputs(self) -> Sequence[Output]: ...

    def messages(self, follower: str, update: bytes, generated_at: float) -> Sequence[Any]: ...


class BytesAdapter:
    """Each update as its bytes (no header: the type has none)."""

    def __init__(self) -> None:
        self.outputs = (Output("update", UPDATE_BYTES),)  # checked when made: the ros2 extra
        types = [message_class(f"std_msgs/msg/{name}") for name in ("MultiArrayLayout",
                                                                    "UInt8MultiArray")]
        self._layout, self._message = types[0](dim=[], data_offset=0), types[1]

    def messages(self, follower: str, update: bytes, generated_at: float) -> Sequence[Any]:
        return [self._message(layout=self._layout, data=np.frombuffer(update, np.uint8))]


ENTRY_POINTS = "wiswarm_zenoh.update_adapters"
_REGISTRY: dict[str, UpdateAdapter] = {}


def register_adapter(name: str, adapter: UpdateAdapter) -> None:
    """Make ``adapter`` known as ``name`` in this process (``adapter(name)``)."""
    _REGISTRY[name] = adapter


def adapter(name: str) -> UpdateAdapter:
    """The adapter ``name``: "bytes" (the default), one registered in this process, or
    an installed entry point's (loaded once); ValueError naming them all otherwise."""
    if name == "bytes":
        return BytesAdapter()
    if name not in _REGISTRY:
        for point in entry_points(group=ENTRY_POINTS, name=name):
            loaded = point.load()
            register_adapter(name, loaded() if isinstance(loaded, type) else loaded)
            break
        else:
            raise ValueError(f"no update adapter {name!r}: one of "
                             f"{', '.join(adapter_names())}")
    return _REGISTRY[name]


def adapter_names() -> list[str]:
    """Every adapter's name: the default, those registered, those installed."""
    installed = {point.name for point in entry_points(group=ENTRY_POINTS)}
    return ["bytes", *sorted(installed | set(_REGISTRY))]
