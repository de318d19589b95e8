"""What makes ``episode_log.jsonl`` valid (``schemas.parse_episode_log``), and that a track
checks it so: an empty log (or one with no valid record) is a failed file check; a record
out of time order, with an unknown value or an exception_detected record without its type
is left out and noted by its line and value, and the rest of the log is graded."""

from __future__ import annotations

import pytest

from plugins import load_track
from schemas import LogRecord, SchemaError, ignored_note, left_out_lines, parse_episode_log


def test_a_valid_log() -> None:
    text = ('{"step": 0, "stage": "explore", "event": "stage"}\n\n'
            '{"step": 4, "event": "exception_detected", "exception_type": "target_moved"}\n'
            '{"step": 4, "event": "model_update"}\n')
    records = parse_episode_log(text)
    assert [r.step for r in records] == [0, 4, 4]


@pytest.mark.parametrize("text", [b"", b"\n\n  \n"], ids=["empty", "blank lines"])
def test_an_empty_log_is_refused(text: bytes) -> None:
    with pytest.raises(SchemaError) as e:
        parse_episode_log(text, source="episode_log.jsonl")
    assert e.value.summary.startswith("episode_log.jsonl: empty: a log holds at least one")


def test_records_out_of_time_order_are_left_out_by_line() -> None:
    text = ('{"step": 5, "event": "note"}\n{"step": 7, "event": "note"}\n'
            '\n{"step": 6, "event": "plan"}\n{"step": 8, "event": "note"}\n')
    records = parse_episode_log(text, source="log")
    assert [r.step for r in records] == [5, 7, 8]
    assert records.left_lines == (4,) and records.lines == 4
    assert left_out_lines(records) == ("line 4: step: 6 comes after step 7: records are in "
                                       "time order",)


def test_an_exception_record_without_its_type_is_left_out() -> None:
    records = parse_episode_log('{"step": 1, "event": "exception_detected"}\n'
                                '{"step": 2, "event": "note"}\n', source="log")
    assert [r.step for r in records] == [2]
    (line,) = left_out_lines(records)
    assert line.startswith("line 1:") and "exception_type" in line
    with pytest.raises(ValueError, match="exception_type"):
        LogRecord(step=1, event="exception_detected")


def test_one_unknown_value_leaves_out_its_line_not_the_log() -> None:
    text = ('{"step": 0, "event": "stage", "stage": "exploration", "why": 1}\n'
            '{"step": 3, "event_type": "perception", "seen": [1]}\n'
            '{"step": 9, "event": "exception_detected", "exception_type": "door_lock"}\n'
            'not json\n')
    records = parse_episode_log(text)
    assert [r.step for r in records] == [0, 9]
    assert records.left_lines == (2, 4)
    note = ignored_note("episode_log.jsonl", records)
    assert note is not None
    assert "not graded, ignored: line 1: why, line 2: seen" in note
    assert "2 of 4 lines left out, not graded (the rest is)" in note
    assert "line 2: event_type: got 'perception', not ours: write 'observation'" in note
    assert "line 4: not valid JSON" in note


def test_a_file_with_no_valid_record_is_refused_whole() -> None:
    with pytest.raises(SchemaError, match="not valid JSON"):
        parse_episode_log(b"step 1: saw a door\nstep 2: opened it\n")
    with pytest.raises(SchemaError, match="line 1: event: got 'perception'"):
        parse_episode_log(b'{"step": 1, "event": "perception"}\n')


@pytest.mark.parametrize("track", ["sanity", "track1", "track2"])
def test_every_track_grades_a_log_with_a_bad_line(track: str) -> None:
    plugin = load_track(track)
    log = b'{"step": 0, "event": "stage"}\n{"step": 1, "event": "recovery_failed"}\n'
    parsed, checks = plugin.verify_files({"episode_log.jsonl": log})
    (check,) = [c for c in checks if c.name == "episode_log.jsonl"]
    assert check.ok and "1 of 2 lines left out" in check.reason
    assert "'recovery_failed', not one of ours" in check.reason
    assert len(parsed["episode_log.jsonl"]) == 1


@pytest.mark.parametrize("track", ["sanity", "track1", "track2"])
def test_every_track_fails_the_file_check_of_an_empty_log(track: str) -> None:
    plugin = load_track(track)
    parsed, checks = plugin.verify_files({"episode_log.jsonl": b""})
    (check,) = [c for c in checks if c.name == "episode_log.jsonl"]
    assert not check.ok and "empty" in check.reason.splitlines()[0]
    assert "episode_log.jsonl" not in parsed
