"""Applications built on the wiswarm_zenoh middleware (mobility tracking, demos)."""
