"""Tests of the sans-I/O core (wiswarm_zenoh.core): explicit ``now``, seeded randomness."""
