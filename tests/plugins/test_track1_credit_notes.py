"""Track 1's notes wherever the score throws credit away: an early detection, ids that
match nothing the agent was shown, log steps that disagree with the host, unanswered
queries, and the keys of the files nothing grades (graded anyway). The score itself does
not move: the notes only say why."""

from __future__ import annotations

import json
from typing import Any

import pytest

from plugins import load_track
from plugins.track1._episode import shown_from, shown_record
from plugins.track1._types import ShownRecord
from plugins.track1.audit import Shown
from schemas import LogRecord, WorldModel
from tests.plugins.test_track1_scoring import (
    GT,
    _exc,
    _input,
    _planned,
    graded,
    outcome,
    perfect_model,
    truth,
)


def _card(o: Any, **kw: Any):  # noqa: ANN202
    return load_track("track1").score(_input(o, **kw))


def _shown(ids: dict[int, int], rooms: dict[int, int]) -> ShownRecord:
    return shown_record(Shown(ids=dict(ids), rooms=dict(rooms)))


def test_an_exception_detected_before_it_happened_is_noted_as_a_false_alarm() -> None:
    locked = truth(doors=[d.model_copy(update={"state": "locked"}) if d.id == 2 else d
                          for d in GT.doors])
    o = outcome(exception=_exc("door_lock", 2, step=180, effect=185),
                planned_exception=_planned("door_lock"), steps=300, gt_final=locked,
                stage_steps={"exploration": 60, "planning": 10, "execution": 230})
    log = [LogRecord(step=31, stage="exploration", event="exception_detected",
                     exception_type="door_lock")]
    card = _card(o, model=perfect_model(), log=log, steps=300)
    note = next(n for n in card.notes if "step 31" in n)
    assert "the exception came at step 180: a false alarm" in note
    assert card.metrics["recovery_detected"] == 0.0
    # the right claim in time: no note
    ok = _card(o, model=perfect_model(), steps=300, log=[LogRecord(
        step=186, stage="execution", event="exception_detected", exception_type="door_lock")])
    assert not any("false alarm" in n for n in ok.notes)


def test_a_claim_of_another_type_and_one_too_late_are_noted() -> None:
    o = outcome(exception=_exc("door_lock", 2, step=100, effect=105),
                planned_exception=_planned("door_lock"), steps=300)
    log = [LogRecord(step=110, event="exception_detected", exception_type="tool_substitution"),
           LogRecord(step=200, event="exception_detected", exception_type="door_lock")]
    notes = _card(o, model=perfect_model(), log=log, steps=300).notes
    assert any("step 110" in n and "the exception was door_lock: a false alarm" in n
               for n in notes)
    assert any("step 200" in n and "after the window" in n for n in notes)


def test_room_ids_that_match_nothing_shown_are_counted() -> None:
    model = perfect_model()
    renamed = WorldModel.model_validate({  # its own room numbering
        "rooms": [{"id": i + 100} for i in range(4)],
        "connections": [{"rooms": [100, 101]}, {"rooms": [102, 103]}]})
    o = outcome(stage_steps={"exploration": 50}).model_copy(update={"shown": _shown(
        {i: 1 for i in (1, 2, 3, 10, 11, 20, 21, 22, 30, 31)}, {0: 0, 1: 5, 2: 9})})
    card = _card(o, model=renamed)
    assert any("0 of 4 room ids match a room the agent was shown by step 50" in n
               for n in card.notes), card.notes
    honest = _card(o, model=model)
    assert not any("ids match" in n for n in honest.notes), honest.notes
    # an id never detected is counted too
    o = o.model_copy(update={"shown": _shown({1: 1}, {0: 0, 1: 0, 2: 0})})
    assert any("ids match an id the agent was shown" in n
               for n in _card(o, model=model).notes)


def test_the_shown_record_round_trips_through_json() -> None:
    shown = Shown(ids={3: 1, 7: 4}, rooms={0: 0}, states={3: {"locked": 9}})
    back = shown_from(ShownRecord.model_validate(json.loads(
        shown_record(shown).model_dump_json())))
    assert back == shown
    assert shown_from(None) is None


def test_log_steps_past_the_host_count_and_unanswered_queries_are_noted() -> None:
    o = outcome(steps=100, stage_steps={"exploration": 40, "planning": 10, "execution": 50},
                queries=graded({"q0": 0}))
    log = [LogRecord(step=0, stage="exploration", event="stage"),
           LogRecord(step=5, stage="execution", event="stage"),
           LogRecord(step=900, stage="execution", event="note")]
    notes = _card(o, model=perfect_model(), log=log).notes
    assert any("1 record(s) name a step past the 100 the host served" in n for n in notes)
    assert any("step 5, stage in 'execution', which ran over host steps 50-100" in n
               for n in notes)
    assert any("5 of 6 queries left unanswered" in n for n in notes)


@pytest.mark.parametrize("split", ["dev"])
def test_a_real_episode_records_what_it_showed(split: str) -> None:
    plugin = load_track("track1")
    episode = plugin.make_episode(plugin.make_scenario(seed=3, split=split, params={
        "render_rgbd": False}))
    try:
        episode.reset()
        for stage in ("exploration",):
            episode.on_stage_start(stage)
            for _ in range(3):
                episode.step(stage, {"primitive": 1, "move": [0.0, 0.5]})
        raw = episode.outcome()
    finally:
        episode.close()
    shown = shown_from(raw.shown)
    assert shown is not None and shown.rooms, "the room the robot starts in is shown"
    assert all(step <= 3 for step in shown.rooms.values())


def test_the_protocol_page_names_the_vocabulary_the_scores_use() -> None:
    """Generated from where the words live (issue 22, item 6, in part)."""
    from plugins.protocol_doc import DOC
    from simhost.worlds.track1._actions import REASONS

    text = DOC.read_text()
    assert all(f"`{r}`" in text for r in REASONS)
    assert "| `standard` | 1.3 m | 0.8 m | 1.5 m |" in text
    for family in ("assembly", "insertion", "opening", "rotation", "tool_use"):
        assert f"| `{family}` |" in text
    assert "`drawer_opening within`" in text and "`button_travel >=`" in text
    assert "| `obs_force` | float32 T+1 × 6 |" in text and "`wipe` (dirty → clean)" in text


#: A model in the shapes of a team that names its ids (our own fixture, issue 35): names
#: where the host gave numbers, beside numbers that match nothing shown.
NAMED = {
    "rooms": [{"id": "living_room_3"}, {"id": "kitchen_1"}, {"id": 0}],
    "connections": [{"rooms": ["living_room_3", "kitchen_1"], "door": "door_2"}],
    "doors": [{"id": "door_2", "state": "closed"}, {"id": 2, "state": "open"}],
    "objects": [{"id": "mug_1", "category": "mug", "room": "kitchen_1"},
                {"id": 999, "category": "apple", "room": 0}],
}


def test_ids_that_are_names_and_ids_that_match_nothing_each_get_a_note() -> None:
    o = outcome(stage_steps={"exploration": 50}).model_copy(update={"shown": _shown(
        {i: 1 for i in (1, 2, 3, 10, 11, 20, 21, 22, 30, 31)}, {0: 0, 1: 5, 2: 9})})
    notes = _card(o, model=WorldModel.model_validate(NAMED)).notes
    assert ("world model: 2 of 4 ids are names, not the numbers observations show "
            "(door_2, mug_1): they match nothing; entries are graded by the shown ids"
            in notes), notes
    assert any(n.startswith("world model: 2 of 3 room ids are names, not the numbers "
                            "observations show (living_room_3, kitchen_1)") for n in notes)
    assert any("ids match an id the agent was shown" in n and "999" in n for n in notes)
    assert not any("are names" in n for n in _card(o, model=perfect_model()).notes)


def test_check_files_names_the_ids_that_are_names() -> None:
    _, checks = load_track("track1").verify_files({
        "world_model.json": json.dumps(NAMED).encode(),
        "episode_log.jsonl": b'{"step": 0, "event": "stage"}\n'})
    (check,) = [c for c in checks if c.name == "world_model.json"]
    assert check.ok
    lines = check.reason.splitlines()
    assert any(x.startswith("2 of 4 ids are names, not the numbers observations show "
                            "(door_2, mug_1): they match nothing (on every split but "
                            "vision") for x in lines), lines
    assert any(x.startswith("2 of 3 room ids are names") for x in lines)
