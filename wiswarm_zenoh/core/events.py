"""What the leader reports back to its shell after a reply, a timeout or a poll's end."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol


@dataclass(frozen=True, slots=True)
class Delivered:
    """A whole update arrived and was fresher than anything before it from this follower."""

    follower: str
    payload: bytes
    generated_at: float  # on the leader's clock
    delivered_at: float  # when its last fragment came, on the leader's clock
    update_seq: int

    @property
    def age(self) -> float:
        """Seconds between generation and delivery."""
        return self.delivered_at - self.generated_at


@dataclass(frozen=True, slots=True)
class TimedOut:
    """The in-flight poll got no valid reply before its deadline."""

    follower: str
    poll_seq: int


@dataclass(frozen=True, slots=True)
class Rejected:
    """A reply that could not be used: malformed, mismatched, or failing its checksum."""

    follower: str
    reason: str


@dataclass(frozen=True, slots=True)
class Stale:
    """A well-formed reply that is no longer wanted (old poll, older update, unknown sender)."""

    follower: str
    reason: str


@dataclass(frozen=True, slots=True)
class Silent:
    """None of the follower's last ``polls`` polls was answered: it is probed alone now.
    ``answered_before``: False for a member that never gave a valid answer (silent
    from its first unanswered poll)."""

    follower: str
    polls: int
    answered_before: bool = True


@dataclass(frozen=True, slots=True)
class Answering:
    """A silent follower answered again (after ``silent_for`` seconds)."""

    follower: str
    silent_for: float


Event = Delivered | TimedOut | Rejected | Stale | Silent | Answering
"""What ``Leader.next_event`` returns: one of these, or None when there is nothing left."""


class EventSource(Protocol):
    def next_event(self) -> Event | None: ...


def drain(source: EventSource) -> list[Event]:
    """Every event ``source`` (a leader) has now (``next_event`` until None), for shells
    that have nothing to overlap with the work it does."""
    events = []
    while (event := source.next_event()) is not None:
        events.append(event)
    return events
