"""Errors raised by the core."""


class WireError(Exception):
    """Bytes from the network that are not a valid message.

    Distinct from ``ValueError`` (misuse by the local caller): shells catch exactly this,
    count it against the sender and carry on.
    """
