"""What makes ``episode_log.jsonl`` valid (``schemas.parse_episode_log``), and that a track
checks it so: an empty log, records out of time order or an exception_detected record
without its type are a failed file check with the reason, not an accepted log."""

from __future__ import annotations

import pytest

from plugins import load_track
from schemas import LogRecord, SchemaError, parse_episode_log


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


def test_records_out_of_time_order_are_refused_by_line() -> None:
    text = ('{"step": 5, "event": "note"}\n{"step": 7, "event": "note"}\n'
            '\n{"step": 6, "event": "plan"}\n')
    with pytest.raises(SchemaError) as e:
        parse_episode_log(text, source="log")
    assert e.value.problems == ["line 4: step: 6 comes after step 7: records are in time "
                                "order"]


def test_an_exception_record_names_its_type() -> None:
    with pytest.raises(SchemaError) as e:
        parse_episode_log('{"step": 1, "event": "exception_detected"}\n', source="log")
    assert "line 1:" in e.value.summary and "exception_type" in e.value.summary
    with pytest.raises(ValueError, match="exception_type"):
        LogRecord(step=1, event="exception_detected")


@pytest.mark.parametrize("track", ["sanity", "track1", "track2"])
def test_every_track_fails_the_file_check_of_an_empty_log(track: str) -> None:
    plugin = load_track(track)
    parsed, checks = plugin.verify_files({"episode_log.jsonl": b""})
    (check,) = [c for c in checks if c.name == "episode_log.jsonl"]
    assert not check.ok and "empty" in check.reason.splitlines()[0]
    assert "episode_log.jsonl" not in parsed
