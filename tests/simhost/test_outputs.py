"""``OutputFiles``: the light client's way of writing /output (atomic, schema-checked)."""

from __future__ import annotations

import json

import pytest

from schemas import CONTAINER, WORLD_MODEL_VERSION, LogRecord, WorldModel, parse_jsonl
from simhost.client import OutputFileError, OutputFiles


def test_model_is_written_atomically_under_its_name(tmp_path):
    files = OutputFiles(tmp_path)
    path = files.write(WorldModel(version=WORLD_MODEL_VERSION, rooms=[{"id": "kitchen"}]))
    assert path == tmp_path / "world_model.json"
    assert json.loads(path.read_text())["rooms"] == [{"id": "kitchen"}]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["world_model.json"], "temp file left"


def test_a_mapping_is_checked_against_its_schema_first(tmp_path):
    files = OutputFiles(tmp_path)
    with pytest.raises(OutputFileError, match=r"world_model\.json: version: Input should be"):
        files.write({"version": "v0", "rooms": []}, "world_model.json")
    assert not any(tmp_path.iterdir()), "a rejected file was written"
    with pytest.raises(OutputFileError, match="plain file name"):
        files.write({"a": 1}, "../escape.json")


def test_log_appends_one_valid_record_per_line(tmp_path):
    files = OutputFiles(tmp_path)
    files.log(step=1, stage="exploration", event="observation")
    files.log(LogRecord(step=2, stage="execution", event="exception_detected",
                        exception_type="door_lock"))
    with pytest.raises(OutputFileError, match="event"):
        files.log(step=3, event="teleported")
    files.close()
    records = parse_jsonl((tmp_path / "episode_log.jsonl").read_bytes(), source="log")
    assert [r.step for r in records] == [1, 2]
    assert records[1].exception_type == "door_lock"


def test_folder_defaults_to_the_contract(monkeypatch, tmp_path):
    monkeypatch.setenv(CONTAINER.env_output, str(tmp_path))
    assert OutputFiles().folder == tmp_path
    monkeypatch.delenv(CONTAINER.env_output)
    assert str(OutputFiles().folder) == CONTAINER.output_dir
