"""``events.jsonl`` as one discriminated union: every kind the driver writes reads back as
the same model; a cut line, an unknown kind or a bad field reads as nothing."""

from __future__ import annotations

import pytest

from schemas import (
    Committed,
    EpisodeWhere,
    Finished,
    Retried,
    Started,
    Stopped,
    Submitted,
    event_line,
    parse_event,
)

WHERE = EpisodeWhere(submission="team-a", split="standard", index=3, retry=1, episode="ep12")
EVENTS = [
    Submitted(episodes=40, board_node="n1"),
    Started(**WHERE.model_dump(), node="n2", host="h", pid=77),
    Committed(**WHERE.model_dump(), node="n2", status="completed", score=0.42),
    Committed(**WHERE.model_dump(), node="n2", status="completed", score=0.42,
              event="duplicate"),
    Retried(**WHERE.model_dump(), node=None, message="NodeDiedError: lost"),
    Retried(**WHERE.model_dump(), node="n3", message="x", event="quarantined"),
    Finished(committed=39, cancelled=False, wall_s=12.5),
    Stopped(pending=3),
    Stopped(event="failed", reason="store", message="disk full", pending=1),
]


@pytest.mark.parametrize("event", EVENTS, ids=lambda e: e.event)
def test_every_event_reads_back_as_itself(event: object) -> None:
    line = event_line(event)  # type: ignore[arg-type]
    assert line.endswith("\n") and line.count("\n") == 1
    assert parse_event(line) == event


def test_cut_unknown_and_bad_lines_read_as_nothing() -> None:
    line = event_line(EVENTS[2])
    assert parse_event(line[: len(line) // 2]) is None
    assert parse_event('{"event": "exploded", "at": 1}') is None
    assert parse_event('{"event": "committed", "at": 1, "submission": "a"}') is None
    assert parse_event("") is None


def test_a_newer_writers_extra_field_is_ignored() -> None:
    got = parse_event('{"event": "submitted", "at": 5, "episodes": 2, "gpu": "h100"}')
    assert got == Submitted(at=5, episodes=2)
