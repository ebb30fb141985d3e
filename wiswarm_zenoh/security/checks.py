"""A node's config checked against what it is started as, before its session opens:
a secured site's config names who and what it was written for (``wiswarm security``);
a node started otherwise would run silently dead, or as someone else.
"""

from __future__ import annotations

import json
from pathlib import Path

import zenoh

from wiswarm_zenoh.transport.tls_files import check_tls, tls_files
from wiswarm_zenoh.usage import UsageError


def check_identity(config_file: str | None, name: str) -> None:
    """A node started as ``name`` with ``config_file`` must hold ``name``'s certificate:
    the router's rules know it by its certificate's common name (``<site>/<name>`` in a
    site), not by ``--id``."""
    if config_file is None:
        return
    if not Path(config_file).is_file():
        raise UsageError(f"config file {config_file}: no such file (no config for {name!r})")
    try:
        config = zenoh.Config.from_file(config_file)
    except zenoh.ZError:
        return  # the session's own config checks report it, with Zenoh's words
    cert = check_tls(config).get("connect_certificate")
    from wiswarm_zenoh.security.pki import common_name

    if cert is not None and common_name(cert).rpartition("/")[2] != name:
        path = tls_files(config)["connect_certificate"]
        raise UsageError(f"certificate {path} (in {config_file}) is {common_name(cert)}'s, "
                         f"not {name}'s: use {name}'s config, or "
                         f"`wiswarm security add-follower` to make one")


def _written_for(config_file: str | None) -> dict[str, object] | None:
    """What ``wiswarm security`` wrote ``config_file`` for (None: not one of ours)."""
    if config_file is None or not Path(config_file).is_file():
        return None
    try:
        metadata = json.loads(zenoh.Config.from_file(config_file).get_json("metadata"))
    except (zenoh.ZError, ValueError):
        return None  # the session's own config checks report it, with Zenoh's words
    ours = metadata.get("wiswarm") if isinstance(metadata, dict) else None
    return ours if isinstance(ours, dict) else None


def check_swarm(config_file: str | None, swarm: str) -> None:
    """A node started for ``swarm`` with a config that ``wiswarm security`` wrote for
    another swarm would run silently dead (the router's rules cover that swarm's keys
    only): said in one line instead."""
    written_for = (_written_for(config_file) or {}).get("swarm")
    if isinstance(written_for, str) and written_for != swarm:
        raise UsageError(f"{config_file} was written for swarm {written_for!r}, whose rules "
                         f"cover its keys only: pass --swarm {written_for} (or make this "
                         f"swarm's configs with wiswarm security init --swarm {swarm})")


def check_upstream(config_file: str | None, upstream: str | None, site: str) -> None:
    """Likewise upstream: an edge leader's config lets it answer the cloud's swarm for
    its own site's followers only, and another leader's for none."""
    ours = _written_for(config_file)
    if ours is None:
        return
    written, swarm = ours.get("upstream"), ours.get("swarm")
    if written is None and upstream is not None:
        raise UsageError(f"{config_file} was written for a leader with no swarm upstream, "
                         f"whose rules let it serve none: leave out --upstream")
    if written is not None and (upstream, site) != (written, swarm):
        raise UsageError(f"{config_file} was written for the edge leader of site {swarm!r} under "
                         f"{written!r}, whose rules let it serve {written!r} as {swarm!r} "
                         f"only: pass --upstream {written} (and no other --site)")
