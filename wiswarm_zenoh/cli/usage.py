"""Moved: see wiswarm_zenoh.usage (temporary, until every importer is switched)."""
from wiswarm_zenoh.usage import OneLineParser, UsageError

__all__ = ["OneLineParser", "UsageError"]
