"""Which liveliness tokens are there, from a watch and from answers asked again: the
bookkeeping of ``discovery``, with no I/O (h11's model: state in one place, events in).

Zenoh tells of tokens two ways, and in peer mode neither alone is enough (issue 40,
``bench_liveliness_answers``, ``bench_discovery``): a liveliness subscriber (the watch)
is told of each declaration and undeclaration, but its history, asked once at its start,
can lack a token that is there, and then it never hears of it; a liveliness get (an
answer) can lack a token that is there too, about one answer in five on a busy host.
So: what the watch saw come stands until the watch sees it go; answers add what the
watch missed, and take away only what answers alone gave, once ``drop_after`` answers in
a row, spanning at least ``drop_seconds``, lack it. In peer mode most answers can be
short, and four asked a tenth of a second apart prove little (a loaded testbed run,
where a follower started again got 3 deliveries against its neighbour's 181, most likely
lost it so); a token truly gone is only polled in vain a little longer. An answer that
lacks a token the watch holds is known to be short: it brings what it holds, but proves
nothing gone (in peer mode, most answers at N = 1000 held none or part of the tokens,
bench_liveliness_answers). A token the watch saw go is not brought back by an answer
asked before it went (a stale one), only by ``confirm`` answers in a row asked after it
that hold it (a follower that came back while the watch missed it again); once an
answer asked after it lacks it too, it is forgotten, and a later answer holding it is
news as any other.
"""

from __future__ import annotations

from dataclasses import dataclass, field

CONFIRM = 2  # answers in a row that bring back a token the watch saw go
DROP_AFTER = 4  # answers in a row that take away a token answers alone gave,
DROP_SECONDS = 2.0  # and the time they must span at least


@dataclass
class Changes:
    """Tokens that came and went by an answer (the watch's own changes are its own)."""

    came: list[str] = field(default_factory=list)
    went: list[str] = field(default_factory=list)


@dataclass
class TokenTable:
    """The tokens there, by key; feed it the watch's samples (``saw``) and the answers
    (``asking``, then ``answered`` with that ticket)."""

    confirm: int = CONFIRM
    drop_after: int = DROP_AFTER
    drop_seconds: float = DROP_SECONDS
    _watched: set[str] = field(default_factory=set)  # the watch saw come, not go
    _answered: dict[str, tuple[int, float]] = field(default_factory=dict)  # answers alone
    # gave: (answers in a row that lacked it since, when the first of them came)
    _went: dict[str, tuple[int, int]] = field(default_factory=dict)  # the watch saw go,
    # no answer since lacked it: (tickets issued by then, answers after that held it)
    _tickets: int = 0

    @property
    def present(self) -> set[str]:
        return self._watched | set(self._answered)

    def __len__(self) -> int:
        return len(self._watched) + len(self._answered)

    def __contains__(self, key: str) -> bool:
        return key in self._watched or key in self._answered

    def saw(self, key: str, alive: bool) -> bool:
        """The watch saw ``key`` come (``alive``) or go: whether its presence changed."""
        was = key in self
        self._answered.pop(key, None)
        if alive:
            self._watched.add(key)
            self._went.pop(key, None)
        else:
            self._watched.discard(key)
            self._went[key] = (self._tickets, 0)
        return was != alive

    def asking(self) -> int:
        """A ticket for an answer about to be asked for."""
        self._tickets += 1
        return self._tickets

    def answered(self, ticket: int, keys: set[str], now: float) -> Changes:
        """A whole answer (one that timed out says nothing: do not pass it) asked with
        ``ticket`` and come at ``now``: the tokens it brought and the ones it showed
        gone."""
        changes = Changes()
        whole = self._watched <= keys
        for key in sorted(keys - self._watched - set(self._answered)):
            went = self._went.get(key)
            if went is not None:
                issued, held = went
                if ticket <= issued:
                    continue  # asked before the watch saw it go: stale
                if held + 1 < self.confirm:
                    self._went[key] = (issued, held + 1)
                    continue
                del self._went[key]
            self._answered[key] = (0, now)
            changes.came.append(key)
        for key in self._answered.keys() & keys:
            self._answered[key] = (0, now)
        if not whole:
            return changes
        for key, (issued, _) in list(self._went.items()):
            if key not in keys and ticket > issued:
                del self._went[key]  # gone by both: a later answer holding it is news
        for key in sorted(set(self._answered) - keys):
            lacked, since = self._answered[key]
            since = now if lacked == 0 else since
            if lacked + 1 >= self.drop_after and now - since >= self.drop_seconds:
                del self._answered[key]
                changes.went.append(key)
            else:
                self._answered[key] = (lacked + 1, since)
        return changes
