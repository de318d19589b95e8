"""A bad value in an agent's file gets ours only where it means the same thing
(``schemas.VALUE_SYNONYMS``), else the list of ours: never a guess by spelling (issue 35:
5 of 9 spelling guesses for a team's event values were wrong)."""

from __future__ import annotations

from typing import get_args

import pytest

from schemas import EVENT_MEANINGS, VALUE_SYNONYMS, parse_episode_log
from schemas._files import ExceptionType, LogEvent
from schemas._io import value_hint

OURS = {"event": get_args(LogEvent), "exception_type": get_args(ExceptionType)}


def test_every_synonym_names_a_value_of_ours_and_none_is_ours() -> None:
    assert set(VALUE_SYNONYMS) == set(OURS)
    for field, table in VALUE_SYNONYMS.items():
        assert set(table.values()) <= set(OURS[field]), field
        assert not set(table) & set(OURS[field]), field


def test_every_event_has_its_one_line_meaning() -> None:
    assert list(EVENT_MEANINGS) == list(get_args(LogEvent))
    graded = [e for e, m in EVENT_MEANINGS.items() if "not graded" not in m]
    assert graded == ["exception_detected"]


@pytest.mark.parametrize(("theirs", "ours"), [
    ("perception", "observation"), ("execution_start", "stage"),
    ("exception", "exception_detected"), ("execution_exception", "exception_detected"),
    ("replanning", "replan"), ("world_model_update", "model_update"),
])
def test_a_synonym_is_answered_with_ours_and_its_meaning(theirs: str, ours: str) -> None:
    hint = value_hint("event", theirs, get_args(LogEvent))
    assert hint.startswith(f"got {theirs!r}, not ours: write {ours!r}")
    assert EVENT_MEANINGS[ours] in hint


@pytest.mark.parametrize("theirs", ["recovery_failed", "execution_end", "perceive_room",
                                    "task_complete"])
def test_a_value_with_no_synonym_gets_the_list_of_ours_not_a_guess(theirs: str) -> None:
    text = (f'{{"step": 0, "event": "stage"}}\n{{"step": 1, "event": "{theirs}"}}\n')
    (line,) = parse_episode_log(text).left_out
    assert line.startswith(f"line 2: event: got {theirs!r}, not one of ours (observation, "
                           "action, plan")
    assert "did you mean" not in line


def test_a_perception_record_is_said_to_be_ungraded() -> None:
    text = '{"step": 0, "event": "stage"}\n{"step": 1, "event": "perception"}\n'
    (line,) = parse_episode_log(text).left_out
    assert "write 'observation' (what the agent saw; not graded)" in line
