"""What the testbed tests that run a whole program share: the channels it left."""

from __future__ import annotations

import re

from wiswarm_zenoh.testbed import list_channels
from wiswarm_zenoh.testbed.ownership import process_start

_RUN_ID = re.compile(r"([0-9a-f]+)-\d+")  # a channel's run id: its maker's pid (hex)-n


def left_behind(before: set[str]) -> list[str]:
    """Channels made since ``before`` by a process that has ended: what a program run in
    the meantime failed to remove. Channels of processes still running (another test
    run, a study on the same machine) are theirs; named ones, ``wiswarm testbed up``'s."""
    return sorted(run_id for run_id in set(list_channels()) - before
                  if (made := _RUN_ID.fullmatch(run_id))
                  and process_start(int(made[1], 16)) is None)
