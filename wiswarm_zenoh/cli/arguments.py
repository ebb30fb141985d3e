"""Moved: see wiswarm_zenoh.options (temporary, until every importer is switched)."""
from wiswarm_zenoh.options.arguments import *  # noqa: F403
