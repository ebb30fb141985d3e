"""Tests of the Zenoh shell: real sessions on loopback, multicast scouting off."""
