"""The token table's rules, event by event: the watch's word stands, answers add what
it missed and take away only what they alone gave."""

from __future__ import annotations

from wiswarm_zenoh.transport.token_table import TokenTable


def test_what_the_watch_saw_stands_whatever_the_answers_lack() -> None:
    table = TokenTable()
    assert table.saw("a", True)
    for _ in range(5):
        changes = table.answered(table.asking(), set(), 0.0)
        assert changes.came == changes.went == []
    assert table.present == {"a"}
    assert not table.saw("a", True)  # told twice: no change
    assert table.saw("a", False) and table.present == set()


def test_an_answer_brings_what_the_watch_missed_and_drop_after_answers_take_it_away() -> None:
    table = TokenTable(drop_after=2, drop_seconds=0.0)
    changes = table.answered(table.asking(), {"a", "b"}, 0.0)
    assert changes.came == ["a", "b"] and table.present == {"a", "b"}
    assert table.answered(table.asking(), {"b"}, 0.0).went == []  # one answer lacking it: kept
    assert table.answered(table.asking(), {"a", "b"}, 0.0).went == []  # back: not in a row
    assert table.answered(table.asking(), {"b"}, 0.0).went == []
    assert table.answered(table.asking(), {"b"}, 0.0).went == ["a"]
    assert table.present == {"b"}


def test_the_watch_takes_over_a_token_answers_brought() -> None:
    table = TokenTable(drop_after=2, drop_seconds=0.0)
    table.answered(table.asking(), {"a"}, 0.0)
    assert not table.saw("a", True)  # already there: no second join
    for _ in range(3):
        assert table.answered(table.asking(), set(), 0.0).went == []
    assert table.saw("a", False)


def test_an_answer_asked_before_the_watch_saw_a_token_go_does_not_bring_it_back() -> None:
    table = TokenTable(confirm=2)
    table.saw("a", True)
    stale = table.asking()
    assert table.saw("a", False)
    assert table.answered(stale, {"a"}, 0.0).came == []
    assert table.present == set()


def test_a_token_gone_by_the_watch_comes_back_by_answers_in_a_row_asked_after() -> None:
    table = TokenTable(confirm=2)
    table.saw("a", True)
    table.saw("a", False)
    assert table.answered(table.asking(), {"a"}, 0.0).came == []  # it may be on its way out
    assert table.answered(table.asking(), {"a"}, 0.0).came == ["a"]  # it is there: back
    assert table.present == {"a"}


def test_a_token_gone_by_both_is_news_to_the_next_answer_holding_it() -> None:
    table = TokenTable(confirm=2)
    table.saw("a", True)
    table.saw("a", False)
    assert table.answered(table.asking(), set(), 0.0).came == []  # gone by both: forgotten
    assert table.answered(table.asking(), {"a"}, 0.0).came == ["a"]


def test_by_default_four_answers_over_2_s_must_lack_a_token_answers_gave() -> None:
    table = TokenTable()
    table.answered(table.asking(), {"a"}, 0.0)
    fast = [table.answered(table.asking(), set(), t).went for t in (1.0, 1.1, 1.2, 1.3, 2.9)]
    assert fast == [[], [], [], [], []]  # four and more, but within 2 s of the first
    assert table.answered(table.asking(), set(), 3.0).went == ["a"]
    table.answered(table.asking(), {"b"}, 4.0)
    slow = [table.answered(table.asking(), set(), t).went for t in (10.0, 20.0, 30.0)]
    assert slow == [[], [], []]  # 20 s, but three answers
    assert table.answered(table.asking(), set(), 31.0).went == ["b"]


def test_an_answer_short_of_a_watched_token_brings_but_takes_nothing_away() -> None:
    table = TokenTable(drop_after=2, drop_seconds=0.0)
    table.saw("w", True)
    assert table.answered(table.asking(), {"w", "a"}, 0.0).came == ["a"]
    for _ in range(5):  # short: it lacks "w", which the watch holds
        changes = table.answered(table.asking(), {"b"}, 0.0)
        assert changes.went == [] and changes.came in (["b"], [])
    assert table.present == {"w", "a", "b"}
    assert table.answered(table.asking(), {"w", "b"}, 0.0).went == []
    assert table.answered(table.asking(), {"w", "b"}, 0.0).went == ["a"]  # whole ones do
