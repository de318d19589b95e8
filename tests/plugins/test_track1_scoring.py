"""Track 1 scoring on a hand-built ground truth: every component, perfect and empty models,
recovery with and without an exception, false alarms, the leaderboard row (Table IV) and
tie-breaks."""

from __future__ import annotations

import math
from typing import Any

import pytest

from plugins import Scenario, ScoringInput, granted_budgets, load_track
from plugins.track1 import GradedQuery, PlannedException, Query, Task, Track1Outcome, _score
from plugins.track1._queries import grade, score_answer, truth_of
from schemas import EpisodeResult, EpisodeStats, LogRecord, ScoreCard, WorldModel
from schemas._result import EpisodeStatus
from simhost.track1 import HouseTruth

# A three-room house: 0 kitchen, 1 hallway, 2 storage; doors 1 (0-1), 2 (1-2), 3 (0-2).
_ROOMS = [(0, "kitchen"), (1, "hallway"), (2, "storage")]
_OBJECTS = [(20, "object", "mug", "red", 0, (1.0, 1.0)), (21, "object", "apple", "green", 2,
            (5.0, 1.0)), (22, "object", "mug", "blue", 2, (5.5, 1.5)),
            (30, "tool", "sponge", "yellow", 1, (3.0, 4.0)),
            (31, "tool", "cloth", "blue", 2, (5.5, 2.0))]


def truth(**changes: Any) -> HouseTruth:
    doc: dict[str, Any] = {
        "seed": 1, "layout_digest": "x",
        "rooms": [{"id": i, "type": t, "bounds": (0, 0, 1, 1), "centre": (0.5, 0.5),
                   "cells": ()} for i, t in _ROOMS],
        "connections": [{"rooms": (0, 1), "door": 1}, {"rooms": (1, 2), "door": 2},
                        {"rooms": (0, 2), "door": 3}],
        "doors": [{"id": 1, "rooms": (0, 1), "state": "open", "position": (0, 0)},
                  {"id": 2, "rooms": (1, 2), "state": "closed", "position": (0, 0)},
                  {"id": 3, "rooms": (0, 2), "state": "open", "position": (0, 0)}],
        "furniture": [],
        "containers": [
            {"id": 10, "kind": "container", "category": "cabinet", "room": 0,
             "position": (0, 0), "yaw": 0, "size": (1, 1, 1), "state": "closed",
             "access": (0, 0, 0)},
            {"id": 11, "kind": "container", "category": "fridge", "room": 0,
             "position": (0, 0), "yaw": 0, "size": (1, 1, 1), "state": "open",
             "access": (0, 0, 0)}],
        "objects": [{"id": i, "kind": k, "category": c, "colour": col, "room": r,
                     "receptacle": 10, "slot": 0, "position": (*xy, 0.9), "state": "none",
                     "held": False, "affordances": ("wipe",) if k == "tool" else ()}
                    for i, k, c, col, r, xy in _OBJECTS],
        "tools": [{"id": 30, "category": "sponge", "colour": "yellow", "affordances": ("wipe",),
                   "available": True},
                  {"id": 31, "category": "cloth", "colour": "blue", "affordances": ("wipe",),
                   "available": True}],
        "affordances": [{"tool": 30, "affordance": "wipe"}, {"tool": 31, "affordance": "wipe"}],
        "removed": (), "robot": {"x": 0, "y": 0, "yaw": 0, "room": 0, "held": -1},
        "start_room": 1, "backup_room": 2,
    }
    doc.update(changes)
    return HouseTruth.model_validate(doc)


GT = truth()


def perfect_model(gt: HouseTruth = GT) -> WorldModel:
    return WorldModel.model_validate({
        "rooms": [{"id": r.id, "type": r.type} for r in gt.rooms],
        "connections": [{"rooms": c.rooms, "door": c.door} for c in gt.connections],
        "doors": [{"id": d.id, "state": d.state} for d in gt.doors],
        "containers": [{"id": c.id, "state": c.state} for c in gt.containers],
        "objects": [{"id": o.id, "category": o.category, "room": o.room,
                     "position": o.position[:2]} for o in gt.objects],
        "affordances": [{"tool": a.tool, "affordance": a.affordance} for a in gt.affordances],
    })


QUERIES = (
    Query(id="q0", kind="object_room", subject=20, text="Which room (id) is the red mug in?"),
    Query(id="q1", kind="door_state", subject=2, text="door 2?"),
    Query(id="q2", kind="room_neighbours", subject=0, text="room 0?"),
    Query(id="q3", kind="container_state", subject=11, text="fridge?"),
    Query(id="q4", kind="tools_for", subject="wipe", text="wipe?"),
    Query(id="q5", kind="object_count", subject="mug", text="How many mugs?"),
)
RIGHT = {"q0": 0, "q1": "closed", "q2": [2, 1], "q3": "open", "q4": [31, 30], "q5": 2}


def graded(answers: dict[str, Any]) -> tuple[GradedQuery, ...]:
    return grade(QUERIES, answers, GT)


def test_the_truth_of_each_query_kind() -> None:
    assert [truth_of(q, GT) for q in QUERIES] == [0, "closed", [1, 2], "open", [30, 31], 2]


def test_a_perfect_model_scores_one_on_every_part() -> None:
    parts = _score.model_parts(perfect_model(), GT, graded(RIGHT))
    assert parts == {"queries": 1.0, "topology": 1.0, "objects": 1.0, "states": 1.0,
                     "affordances": 1.0}
    assert math.isclose(sum(_score.MODEL_PARTS[k] * v for k, v in parts.items()), 1.0)


def test_an_empty_or_missing_model_scores_zero() -> None:
    parts = _score.model_parts(WorldModel(), GT, graded({}))
    assert parts == {"queries": 0.0, "topology": 0.0, "objects": 0.0, "states": 0.0,
                     "affordances": 0.0}
    assert all(v == 0.0 for v in _score.model_parts(None, GT, ()).values())
    assert all(v == 0.0 for v in _score.model_parts(perfect_model(), None, ()).values())


def test_partial_models_score_in_between_against_the_whole_house() -> None:
    doc = perfect_model().model_dump()
    doc["connections"] = doc["connections"][:2] + [{"rooms": [1, 5]}]  # 2 of 3 right, 1 wrong
    doc["objects"][0]["position"] = [1.6, 1.0]  # within the 0.75 m tolerance
    doc["objects"][1]["position"] = [6.0, 1.0]  # 1 m off: no match
    doc["objects"][3]["room"] = "1"  # ids as strings are fine
    del doc["objects"][2]  # never seen: the inventory is graded against the whole house
    doc["doors"][1]["state"] = "open"  # wrong
    del doc["containers"][0]  # missing: wrong
    doc["affordances"].append({"tool": 20, "affordance": "cut"})  # a mug does not cut
    m = WorldModel.model_validate(doc)
    assert math.isclose(_score.topology(m, GT), 2 * 2 / (3 + 3))
    assert math.isclose(_score.inventory(m, GT), 2 * 3 / (5 + 4))
    assert math.isclose(_score.states(m, GT), 3 / 5)
    assert math.isclose(_score.affordances(m, GT), 2 * 2 / (3 + 2))


def test_answers_are_graded_by_kind_and_unknown_scores_zero_never_less() -> None:
    assert score_answer("object_room", "0", 0) == 1.0
    assert score_answer("object_room", True, 1) == 0.0
    assert score_answer("object_room", "unknown", 1) == 0.0
    assert score_answer("door_state", " Closed ", "closed") == 1.0
    assert score_answer("door_state", "UNKNOWN", "closed") == 0.0
    assert score_answer("room_neighbours", [1], [1, 2]) == pytest.approx(2 / 3)
    assert score_answer("tools_for", "30", [30]) == 0.0  # a list is required
    assert score_answer("tools_for", [], []) == 1.0
    assert score_answer("object_count", 3, 2) == pytest.approx(0.5)
    assert score_answer("object_count", 9, 2) == 0.0
    half = {k: v for k, v in RIGHT.items() if k in ("q0", "q1", "q5")}
    parts = _score.model_parts(perfect_model(), GT, graded(half))
    assert parts["queries"] == pytest.approx(3 / 6)


# ------------------------------------------------------------------------ recovery
TASK = Task(text="put the red mug in the fridge in the kitchen", steps=("go",), goals=(
    {"kind": "place", "object": 20, "receptacle": 11, "container": True, "substitutes": (10,),
     "subgoals": ("picked", "reached", "opened", "placed")},))


def outcome(**kw: Any) -> Track1Outcome:
    base: dict[str, Any] = {
        "started": True, "task": TASK, "planned_exception": None, "success": True,
        "goals": [{"subgoals": {"picked": 10, "reached": 20, "opened": 21, "placed": 22},
                   "done": True}],
        "queries": graded(RIGHT), "gt_exploration": GT, "gt_final": GT, "steps": 100,
        "execution": {"steps": 40, "redundant": 0, "reference_length": 10.0,
                      "path_at_success": 10.0}}
    base.update(kw)
    return Track1Outcome.model_validate(base)


def _exc(kind: str, subject: int, step: int = 100, effect: int | None = 105) -> dict:
    return {"type": kind, "goal": 0, "subject": subject, "step": step, "pose": (0.0, 0.0),
            "details": {}, "effect_step": effect}


def _planned(kind: str) -> PlannedException:
    return PlannedException(type=kind, goal=0)  # type: ignore[arg-type]


def _log(*records: tuple[int, str]) -> list[LogRecord]:
    return [LogRecord(step=s, event="exception_detected", exception_type=t)  # type: ignore[arg-type]
            for s, t in records]


def test_recovery_detection_needs_the_right_type_in_the_window() -> None:
    locked_gt = truth(doors=[d.model_copy(update={"state": "locked"}) if d.id == 2 else d
                             for d in GT.doors])
    o = outcome(exception=_exc("door_lock", 2), planned_exception=_planned("door_lock"),
                steps=300, gt_final=locked_gt)
    locked = WorldModel.model_validate({"doors": [{"id": 2, "state": "locked"}]})
    full, had = _score.recovery_parts(o, _log((110, "door_lock")), locked)
    assert had and full == {"detected": 1.0, "updated": 1.0, "completed": 1.0}
    late, _ = _score.recovery_parts(o, _log((105 + _score.DETECT_WINDOW + 1, "door_lock")),
                                    locked)
    assert late["detected"] == 0.0
    wrong, _ = _score.recovery_parts(o, _log((110, "object_relocation")), locked)
    assert wrong["detected"] == 0.0
    spam, _ = _score.recovery_parts(o, _log((50, "door_lock"), (110, "door_lock"),
                                            (111, "tool_substitution")), locked)
    assert spam["detected"] == pytest.approx(max(0.0, 1 - 2 * _score.FALSE_ALARM_COST))
    stale, _ = _score.recovery_parts(o, [], WorldModel())
    assert stale == {"detected": 0.0, "updated": 0.0, "completed": 1.0}


@pytest.mark.parametrize(("kind", "subject", "updated", "stale"), [
    ("container_unavailable", 10, {"containers": [{"id": 10, "state": "unavailable"}]},
     {"containers": [{"id": 10, "state": "closed"}]}),
    ("object_relocation", 21, {"objects": [{"id": 21, "category": "apple", "room": 2}]},
     {"objects": [{"id": 21, "category": "apple", "room": 0}]}),
    ("tool_substitution", 30,
     {"objects": [{"id": 31, "category": "cloth", "room": 2}],
      "affordances": [{"tool": 31, "affordance": "wipe"}]},
     {"objects": [{"id": 30, "category": "sponge", "room": 1}],
      "affordances": [{"tool": 30, "affordance": "wipe"}, {"tool": 31, "affordance": "wipe"}]}),
])
def test_model_update_per_exception_type(kind: str, subject: int, updated: dict,
                                         stale: dict) -> None:
    gt = truth(tools=[t.model_copy(update={"available": t.id != 30}) for t in GT.tools],
               affordances=[a for a in GT.affordances if a.tool != 30])
    o = outcome(exception=_exc(kind, subject), planned_exception=_planned(kind),
                success=False, gt_final=gt)
    ok, _ = _score.recovery_parts(o, [], WorldModel.model_validate(updated))
    bad, _ = _score.recovery_parts(o, [], WorldModel.model_validate(stale))
    assert ok["updated"] == 1.0 and bad["updated"] == 0.0
    empty, _ = _score.recovery_parts(o, [], WorldModel())
    assert empty["updated"] == 0.0  # no credit for knowing nothing


def test_without_an_exception_recovery_is_earned_by_finishing_without_a_false_alarm() -> None:
    clean, had = _score.recovery_parts(outcome(), [], None)
    assert not had and clean == {"completed": 1.0}
    one, _ = _score.recovery_parts(outcome(), _log((10, "door_lock")), None)
    assert one == {"completed": pytest.approx(1 - _score.FALSE_ALARM_COST)}
    failed, _ = _score.recovery_parts(outcome(success=False), [], None)
    assert failed == {"completed": 0.0}
    skipped = outcome(planned_exception=_planned("door_lock"),
                      exception_skipped="door_lock: the route crosses no door")
    assert _score.recovery_parts(skipped, [], None) == ({"completed": 1.0}, False)
    missed = outcome(planned_exception=_planned("door_lock"))
    assert _score.recovery_parts(missed, [], None) == (
        {"detected": 0.0, "updated": 0.0, "completed": 1.0}, True)


# -------------------------------------------------------------------- whole cards
def _input(o: Track1Outcome | dict, *, model: WorldModel | None,
           log: list[LogRecord] | None = None, steps: int = 100,
           invalid: int = 0) -> ScoringInput:
    files: dict[str, Any] = {"episode_log.jsonl": log or []}
    if model is not None:
        files["world_model.json"] = model
    raw = o.model_dump(mode="json") if isinstance(o, Track1Outcome) else o
    return ScoringInput(
        scenario=Scenario(track="track1", split="standard", seed=1),
        status=EpisodeStatus.COMPLETED, end_reason="completed",
        stages_reached=("exploration", "planning", "execution"), outcome=raw, files=files,
        snapshots={"exploration": {"world_model.json": model}} if model else {},
        steps=steps, invalid_actions=invalid, protocol_errors=0,
        stage_budgets_s=granted_budgets(load_track("track1").stages()))


def test_a_perfect_episode_without_exception_scores_one() -> None:
    card = load_track("track1").score(_input(outcome(), model=perfect_model()))
    assert card.total == pytest.approx(1.0)
    assert card.weights == _score.WEIGHTS, "no weight is moved"
    assert card.components["recovery"] == 1.0 and "recovery" not in card.metrics
    assert card.metrics["task_success"] == 1.0 and card.metrics["model_verification"] == 1.0


def test_doing_nothing_scores_zero_on_every_component() -> None:
    o = outcome(success=False, goals=[{"subgoals": {"picked": None, "placed": None},
                                       "done": False}],
                queries=graded({}), planned_exception=_planned("door_lock"), execution={})
    card = load_track("track1").score(_input(o, model=WorldModel(), steps=3))
    assert card.total == 0.0 and all(v == 0.0 for v in card.components.values())
    never = load_track("track1").score(_input({"started": False}, model=None, steps=0))
    assert never.total == 0.0
    missing = load_track("track1").score(_input(o, model=None, steps=0))
    assert any("no valid world_model.json" in n for n in missing.notes)


def test_task_efficiency_and_safety_pay_for_progress_only() -> None:
    o = outcome(success=False, goals=[{"subgoals": {"picked": 3, "reached": None,
                                                    "placed": None}, "done": False}],
                execution={"steps": 40, "redundant": 10, "reference_length": 8.0},
                collisions=4, deadlocks=1)
    card = load_track("track1").score(_input(o, model=perfect_model(), invalid=5))
    assert card.components["task"] == pytest.approx(0.4 / 3)
    assert card.components["efficiency"] == 0.0
    # bad = 5 invalid + 0.5 × 4 collisions + 5 × 1 deadlock = 12 over 100 steps, × progress.
    assert card.components["safety"] == pytest.approx((1 - 2 * 12 / 100) * 0.4 / 3)
    good = outcome(execution={"steps": 40, "redundant": 10, "reference_length": 8.0,
                              "path_at_success": 16.0})
    assert _score.efficiency(good) == pytest.approx(0.5 * (1 - 10 / 40))


def test_an_exception_episode_counts_recovery_at_its_full_weight() -> None:
    gt_final = truth(doors=[d.model_copy(update={"state": "locked"}) if d.id == 2 else d
                            for d in GT.doors])
    o = outcome(planned_exception=_planned("door_lock"), exception=_exc("door_lock", 2),
                gt_final=gt_final)
    model = perfect_model().model_copy(update={"doors": [
        d.model_copy(update={"state": "locked"}) if d.id == 2 else d
        for d in perfect_model().doors]})
    card = load_track("track1").score(_input(o, model=model, log=_log((107, "door_lock"))))
    assert card.weights == _score.WEIGHTS
    assert card.components["recovery"] == pytest.approx(1.0)
    assert card.metrics["recovery"] == pytest.approx(1.0)


# ---------------------------------------------------------------------- leaderboard
def _result(split: str, card: ScoreCard, *, invalid: int = 2, wall: float = 120.0,
            latency: float = 5.0) -> EpisodeResult:
    return EpisodeResult(
        episode="ep", track="track1", split=split, image="x", runtime="local",
        status=EpisodeStatus.COMPLETED, score=card,
        stats=EpisodeStats(steps=100, invalid_actions=invalid, latency_ms_median=latency,
                           peak_memory_bytes=2**30, wall_s=wall),
        started_at=0.0, finished_at=1.0)


def _card(total: float, success: float, model: float, recovery: float | None) -> ScoreCard:
    metrics = {"task_success": success, "model_verification": model}
    if recovery is not None:
        metrics["recovery"] = recovery
    return ScoreCard(track="track1", total=total, components={"task": total},
                     weights={"task": 1.0}, metrics=metrics)


def test_table_iv_row_and_columns() -> None:
    plugin = load_track("track1")
    rows = plugin.summarize([
        _result("standard", _card(0.5, 1.0, 0.8, None)),
        _result("standard", _card(0.3, 0.0, 0.6, 0.5)),
        _result("challenge", _card(0.2, 0.0, 0.4, 0.0)),
    ])
    assert rows["standard"] == pytest.approx(40.0) and rows["challenge"] == pytest.approx(20.0)
    assert rows["final"] == pytest.approx(0.6 * 40 + 0.4 * 20)  # equation (2)
    assert rows["task_success"] == pytest.approx(100 / 3)
    assert rows["model_verification"] == pytest.approx(60.0)
    assert rows["recovery"] == pytest.approx(25.0)  # over the episodes with an exception
    assert rows["invalid_actions"] == pytest.approx(2.0)
    assert rows["peak_mem_gb"] == pytest.approx(1.0) and rows["runtime_min"] == pytest.approx(2.0)
    titles = [c.title for c in plugin.columns]
    assert titles[:9] == ["Std.", "Ch.", "Final", "Task Succ. %", "Model Verif. %",
                          "Recovery %", "Invalid Act/Ep", "Latency ms", "Peak Mem GB"]
    assert all(c.key in rows for c in plugin.columns)
    assert plugin.tie_breaks == ("task_success", "model_verification", "recovery",
                                 "invalid_actions", "runtime_min")
    one_split = plugin.summarize([_result("standard", _card(0.5, 1.0, 0.8, None))])
    assert one_split["challenge"] is None and one_split["final"] == pytest.approx(50.0)
