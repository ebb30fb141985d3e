"""A swarm in Foxglove: MCAP recordings and the live WebSocket server, from the swarm's
key expressions alone (any running swarm), with the SDK's ``foxglove.*`` schemas."""

from wiswarm_zenoh.recording.recording import DEFAULT_HOST, DEFAULT_PORT, SwarmRecording

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "SwarmRecording"]
