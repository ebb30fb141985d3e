"""A live dashboard of a swarm in a browser, fed by Zenoh subscriptions only.

``Dashboard(session, swarm, port)`` serves it on a thread (``url``, ``close()``);
``wiswarm dashboard`` runs one in the foreground.
"""

from wiswarm_zenoh.dashboard.service import DEFAULT_HOST, DEFAULT_PORT, Dashboard

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "Dashboard"]
