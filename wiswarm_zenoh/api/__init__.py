"""The API a robot team embeds, exported as ``wiswarm_zenoh``'s own names."""
