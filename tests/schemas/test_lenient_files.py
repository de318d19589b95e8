"""Files are graded, not rejected, for what is not graded: unknown keys (top level or
inside an entry) and unreadable values of fields nothing grades are ignored and listed;
a file is refused only when what the score reads cannot be read, with every problem at
its path, likely names answered with "did you mean"."""

from __future__ import annotations

import json

import pytest

from plugins import load_track
from schemas import LogRecord, SchemaError, WorldModel
from schemas._generate import render
from schemas._io import (
    IGNORED,
    FileProblems,
    ignored_fields,
    ignored_note,
    parse_episode_log,
    parse_json,
)

#: A world model as a team built it before the runtime existed: its own top-level keys,
#: names and locations on every object, rooms as names.
PORTED = {
    "version": "eagc-world-model/v1", "step": 412,
    "agent_state": {"pose": [1.0, 2.0, 0.3], "holding": None},
    "relations": [["cup", "on", "table"]], "plans": [{"goal": "cup->sink"}],
    "uncertainty": {"cup": 0.2},
    "rooms": ["kitchen", "hallway"],
    "connections": [{"rooms": [0, 1], "door": 1, "traversable": True}],
    "doors": [{"id": 1, "state": "open", "last_seen": 40}],
    "objects": [{"id": 20, "category": "mug", "room": 0, "position": [1.0, 1.0],
                 "name": "red mug", "location": "kitchen counter"},
                {"id": 21, "category": "apple", "room": 2, "position": [5.0, 1.0],
                 "name": "apple", "location": "storage shelf"}],
}


def test_a_ported_world_model_is_graded_and_its_unknown_keys_listed() -> None:
    model = parse_json(json.dumps(PORTED), WorldModel, source="world_model.json")
    assert [o.id for o in model.objects] == [20, 21] and model.connections[0].door == 1
    ignored = ignored_fields(model)
    for key in ("agent_state", "relations", "plans", "uncertainty",
                "objects.0.name", "objects.1.location", "connections.0.traversable"):
        assert key in ignored
    note = ignored_note("world_model.json", model)
    assert note is not None and "agent_state" in note and "objects.*.name" in note
    assert "rooms" not in note, "rooms as names: a near-miss note, not an unreadable key"
    assert model.near_miss_notes()[0].startswith(
        'rooms: 2 of 2 entries are names, not objects ("kitchen", "hallway")')


def test_the_track1_check_and_score_grade_the_ported_file() -> None:
    from tests.plugins.test_track1_scoring import _input, outcome

    plugin = load_track("track1")
    log = b'{"step": 0, "event_type": "stage", "stage": "exploration", "mood": "ok"}\n'
    parsed, checks = plugin.verify_files({"world_model.json": json.dumps(PORTED).encode(),
                                          "episode_log.jsonl": log})
    assert all(c.ok for c in checks), checks
    by = {c.name: c for c in checks}
    assert "agent_state" in by["world_model.json"].reason
    assert parsed["episode_log.jsonl"][0].event == "stage", "event_type is read as event"
    card = plugin.score(_input(outcome(), model=parsed["world_model.json"],
                               log=parsed["episode_log.jsonl"]))
    assert card.components["model"] > 0
    assert any(n.startswith("world_model.json: not graded, ignored: ")
               and "agent_state" in n for n in card.notes), card.notes
    assert any(n.startswith("episode_log.jsonl") and "line 1: mood" in n
               for n in card.notes), card.notes


def test_a_broken_file_lists_every_problem_unknown_keys_first() -> None:
    broken = {**PORTED, "objects": [{"name": f"thing {i}", "category": "cup"}
                                    for i in range(30)],
              "doors": [{"id": 1, "state": "lockd"}], "affordances": "cut"}
    with pytest.raises(FileProblems) as e:
        parse_json(json.dumps(broken), WorldModel, source="world_model.json")
    lines = e.value.lines
    assert lines[0].startswith(f"{IGNORED}: agent_state, relations, plans, uncertainty")
    assert "objects.*.id (objects 0-29): Field required (the file has 'name': did you " \
           "mean 'id'?)" in lines
    assert any(x.startswith("doors.0.state: ") and "did you mean 'locked'?" in x
               for x in lines)
    assert any(x.startswith("affordances: ") for x in lines)
    # the one-line summary names a real problem with its path, none hidden
    assert e.value.summary.startswith("world_model.json: doors.0.state: ")
    assert e.value.detail.splitlines() == e.value.failing + e.value.ignored


def test_a_log_answers_likely_names_with_did_you_mean() -> None:
    log = "\n".join(json.dumps({"step": i, "type": "observation"}) for i in range(1, 489))
    log += "\n" + json.dumps({"step": 500, "event": "exception_detected",
                              "exception_type": "door_locked"})
    with pytest.raises(SchemaError) as e:  # no line is a record: refused whole
        parse_episode_log(log)
    problems = e.value.problems
    assert "lines 1-488: event: Field required (the file has 'type': did you mean " \
           "'event'?)" in problems
    assert "line 489: exception_type: got 'door_locked', not ours: write 'door_lock'" \
        in problems
    assert LogRecord.model_validate({"step": 1, "event_type": "note"}).event == "note"


def test_what_the_score_reads_still_refuses_the_file() -> None:
    with pytest.raises(SchemaError, match="objects: Input should be a valid list"):
        parse_json(b'{"objects": {"id": 1}}', WorldModel, source="w")
    with pytest.raises(SchemaError, match="version"):
        parse_json(b'{"version": "eagc-world-model/v2"}', WorldModel, source="w")


@pytest.mark.parametrize("name", ["world_model.json", "task_model.json",
                                  "episode_log_record.json"])
def test_the_json_schemas_say_what_is_graded_and_that_extra_keys_are_allowed(
        name: str) -> None:
    schema = json.loads(render()[name])
    assert schema["additionalProperties"] is True
    assert any(p.get("graded") for p in schema["properties"].values())
    assert any(not p.get("graded") for p in schema["properties"].values())
    for part in schema.get("$defs", {}).values():
        assert part["additionalProperties"] is True and part.get("examples")


def test_every_example_in_the_schemas_is_valid() -> None:
    from schemas import _files

    for model in vars(_files).values():
        if isinstance(model, type) and issubclass(model, _files._File):
            extra = model.model_config.get("json_schema_extra") or {}
            for example in extra.get("examples", []) if isinstance(extra, dict) else []:
                model.model_validate(example)


def test_the_protocol_page_says_what_is_graded_and_that_extra_keys_are_allowed() -> None:
    from plugins.protocol_doc import DOC, fields_table, track_section

    section = track_section("track1")
    assert "Any other key is allowed" in section and "eagc check-files" in section
    table = fields_table([WorldModel, LogRecord])
    assert ("| `ObjectEntry` | `id` | `id`, `category`, `room`, `position`, `state` | "
            "`colour`, `receptacle` |") in table
    assert "| `LogRecord` | `step`, `event` | `step`, `event`, `exception_type` |" in table
    assert table in DOC.read_text()


def test_track2_grades_a_task_model_with_its_own_keys_and_notes_them() -> None:
    plugin = load_track("track2")
    doc = {"family": "insertion", "stages": ["reach", "grasp"], "confidence": 0.7,
           "variables": [{"name": "peg_pose", "unit": "m"}]}
    parsed, checks = plugin.verify_files({
        "task_model.json": json.dumps(doc).encode(),
        "episode_log.jsonl": b'{"step": 0, "event": "stage"}\n'})
    assert all(c.ok for c in checks), checks
    from plugins import Scenario, ScoringInput, granted_budgets
    from schemas._result import EpisodeStatus

    scenario = plugin.make_scenario(seed=1, split="standard", params={"demo_frames": False},
                                    index=0)
    card = plugin.score(ScoringInput(
        scenario=Scenario(track="track2", split="standard", seed=1,
                          params=scenario.params),
        status=EpisodeStatus.COMPLETED, end_reason="completed", stages_reached=(),
        outcome={}, files=parsed, snapshots={}, steps=0, invalid_actions=0,
        protocol_errors=0, stage_budgets_s=granted_budgets(plugin.stages())))
    assert any(n.startswith("task_model.json: not graded, ignored: confidence")
               and "variables.0.unit" in n for n in card.notes), card.notes


def test_a_strict_file_reports_an_unknown_key_once_as_an_error() -> None:
    """Files whose model forbids extra keys (the campaign, the disclosure) are not graded
    leniently: an unknown key is one error, never also listed as "ignored"."""
    from schemas import CampaignSpec

    doc = {"name": "c", "track": "sanity", "workerz": 2,
           "submissions": [{"team": "a", "image": "x"}]}
    with pytest.raises(SchemaError) as got:
        parse_json(json.dumps(doc), CampaignSpec, source="campaign.yaml")
    text = str(got.value)
    assert text.count("- workerz: unknown key") == 1, text
    assert "ignored" not in text, text


def test_the_sanity_score_card_notes_the_keys_it_ignored() -> None:
    plugin = load_track("sanity")
    parsed, checks = plugin.verify_files({
        "world_model.json": json.dumps(PORTED).encode(),
        "episode_log.jsonl": b'{"step": 0, "event": "stage"}\n'})
    assert all(c.ok for c in checks), checks
    from plugins import ScoringInput, granted_budgets
    from schemas._result import EpisodeStatus

    scenario = plugin.make_scenario(seed=1, split="standard", params={}, index=0)
    card = plugin.score(ScoringInput(
        scenario=scenario, status=EpisodeStatus.COMPLETED, end_reason="completed",
        stages_reached=(), outcome=None, files=parsed, snapshots={}, steps=0,
        invalid_actions=0, protocol_errors=0, stage_budgets_s=granted_budgets(plugin.stages())))
    assert any(n.startswith("world_model.json: not graded, ignored: agent_state")
               for n in card.notes), card.notes
