"""wiswarm-zenoh: Age-of-Information polling middleware (WiSwarm) on Eclipse Zenoh."""

__version__ = "0.1.0"
