"""The models are the schema: generated files never drift, and bad input is named precisely."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from pydantic import TypeAdapter, ValidationError

from schemas import (
    CampaignSpec,
    LogRecord,
    Request,
    SchemaError,
    WorldModel,
    load_json,
    parse_json,
    parse_jsonl,
)
from schemas._generate import JSON_DIR, render


# ------------------------------------------------------------------------------ drift
def test_json_schema_files_match_the_models():
    rendered = render()
    on_disk = {p.name for p in JSON_DIR.glob("*.json")}
    fix = "regenerate them with `python -m schemas` (never edit schemas/json by hand)"
    assert on_disk == set(rendered), f"schemas/json has {sorted(on_disk)}; {fix}"
    stale = [name for name, text in rendered.items() if (JSON_DIR / name).read_text() != text]
    assert not stale, f"{stale} differ from the models: {fix}"


def test_json_schema_files_are_valid_json_with_ids():
    for name, text in render().items():
        doc = json.loads(text)
        assert doc["$id"] == name.removesuffix(".json")
        assert doc["$schema"].startswith("https://json-schema.org/")


# -------------------------------------------------------------------- error messages
def test_load_json_names_the_file_the_field_and_the_problem(tmp_path: Path):
    path = tmp_path / "world_model.json"
    path.write_text(json.dumps({"rooms": [{"id": "kitchen"}, {"id": "hall", "type": 5}],
                                "doors": [{"id": "d1", "state": "ajar"}]}))
    with pytest.raises(SchemaError) as e:
        load_json(path, WorldModel)
    err = e.value
    assert err.source == str(path)
    text = str(err)
    # The first line says it all: the file, its first problem, how many more.
    first = text.splitlines()[0]
    assert first.startswith(f"{path}: ") and first.endswith("(and 1 more problem)")
    assert first == err.summary and any(p in first for p in err.problems)
    assert any(p.startswith("rooms.1.type:") and "string" in p for p in err.problems)
    assert any(p.startswith("doors.0.state:") and "'open'" in p for p in err.problems)


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        (b"{not json", "not valid JSON"),
        (b"\xff\xfe\x00", "not valid JSON"),
        (b"[]", "(top level)"),
        (b'{"version": "eagc-world-model/v9"}', "version:"),
        (b'{"rooms": [{"id": 1}], "extra": 1, "doors": 3}', "doors: Input should be"),
    ],
    ids=["syntax", "not UTF-8", "wrong type", "wrong version", "beside an unknown field"],
)
def test_parse_json_errors(data: bytes, expected: str):
    with pytest.raises(SchemaError) as e:
        parse_json(data, WorldModel, source="out/world_model.json")
    assert str(e.value).startswith("out/world_model.json: ")
    assert expected in str(e.value)


def test_load_json_accepts_a_valid_file(tmp_path: Path):
    path = tmp_path / "world_model.json"
    doc = {"rooms": [{"id": 1, "type": "kitchen"}],
           "objects": [{"id": "target", "position": [0.5, -1.0]}]}
    path.write_text(json.dumps(doc))
    model = load_json(path, WorldModel)
    assert model.objects[0].position == (0.5, -1.0)


def test_parse_jsonl_reports_every_bad_line_by_number():
    lines = [
        '{"step": 0, "event": "observation"}',
        "",
        '{"step": -1, "event": "plan"}',
        '{"step": 3, "event": "teleported"}',
        "{broken",
        '{"step": 5, "event": "exception_detected", "exception_type": "target_moved"}',
    ]
    with pytest.raises(SchemaError) as e:
        parse_jsonl("\n".join(lines), source="episode_log.jsonl")
    err = e.value
    assert err.source == "episode_log.jsonl"
    assert any(p.startswith("line 3: step:") for p in err.problems), err.problems
    assert any(p.startswith("line 4: event:") for p in err.problems), err.problems
    assert any(p.startswith("line 5:") and "JSON" in p for p in err.problems), err.problems
    assert not any(p.startswith(("line 1:", "line 2:", "line 6:")) for p in err.problems)


def test_parse_jsonl_reads_good_lines():
    text = b'{"step": 0, "event": "note"}\n\n{"step": 2, "event": "stage", "stage": "x"}\n'
    records = parse_jsonl(text, source="log")
    assert [r.step for r in records] == [0, 2] and isinstance(records[0], LogRecord)


def test_many_problems_are_summarised():
    text = "\n".join('{"step": "x", "event": "note"}' for _ in range(30))
    with pytest.raises(SchemaError) as e:
        parse_jsonl(text, source="log")
    # the same problem on 30 lines is one line of the report, naming the lines
    assert e.value.problems == ["lines 1-30: step: Input should be a valid integer, unable "
                                "to parse string as an integer"]


# --------------------------------------------------------------------------- campaign
def _campaign(**kw: object) -> dict[str, object]:
    return {
        "name": "c1",
        "track": "sanity",
        "splits": [{"name": "standard", "episodes": 2}],
        "submissions": [{"team": "alpha", "image": "alpha:1"}],
        **kw,
    }


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"splits": [{"name": "a", "episodes": 1}, {"name": "a", "episodes": 2}]},
         "duplicate split names: ['a']"),
        ({"submissions": [{"team": "t", "image": "x"}, {"team": "t", "image": "y"}]},
         "duplicate team names: ['t']"),
        ({"phase": "final"}, "a final campaign needs a secret location"),
        ({"phase": "qualification"}, "a qualification campaign needs a secret location"),
        ({"secret": "hunter2"}, "never the secret itself"),
        ({"splits": []}, "splits:"),
        ({"limits": {"time_scale": 2.0}}, "limits.time_scale:"),
    ],
    ids=["dup split", "dup team", "final no secret", "qualification no secret",
         "literal secret", "no splits", "time scale > 1"],
)
def test_campaign_spec_rejects(change: dict[str, object], message: str):
    with pytest.raises(ValidationError, match="CampaignSpec"):
        CampaignSpec.model_validate(_campaign(**change))
    with pytest.raises(SchemaError) as e:
        parse_json(json.dumps(_campaign(**change)), CampaignSpec, source="campaign.yaml")
    assert message in str(e.value)


def test_campaign_spec_accepts():
    local = CampaignSpec.model_validate(_campaign())
    assert local.phase == "local" and local.secret is None
    final = CampaignSpec.model_validate(_campaign(phase="final", secret="env:EAGC_SECRET"))
    assert final.secret == "env:EAGC_SECRET"
    with pytest.raises(ValidationError):
        final.name = "other"  # frozen


# --------------------------------------------------------------------------- protocol
def test_requests_are_discriminated_on_kind():
    adapter = TypeAdapter(Request)
    assert adapter.validate_json('{"kind": "reset", "seq": 1}').kind == "reset"
    with pytest.raises(ValidationError, match="kind"):
        adapter.validate_json('{"kind": "teleport", "seq": 1}')
    with pytest.raises(ValidationError, match="seq"):
        adapter.validate_json('{"kind": "step", "seq": -1}')
