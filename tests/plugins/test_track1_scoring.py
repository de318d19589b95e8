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
from simhost.worlds.track1 import HouseTruth

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
    return ScoringInput(
        scenario=Scenario(track="track1", split="standard", seed=1),
        status=EpisodeStatus.COMPLETED, end_reason="completed",
        stages_reached=("exploration", "planning", "execution"), outcome=o, files=files,
        snapshots={"exploration": {"world_model.json": model}} if model else {},
        steps=steps, invalid_actions=invalid, protocol_errors=0,
        stage_budgets_s=granted_budgets(load_track("track1").stages()))


def test_an_outcome_given_as_json_scores_as_the_model() -> None:
    o = outcome(exception=_exc("door_lock", 2, step=100, effect=105),
                planned_exception=_planned("door_lock"), steps=300)
    typed = load_track("track1").score(_input(o, model=perfect_model(), steps=300))
    as_json = load_track("track1").score(_input(o.model_dump(mode="json"),
                                                model=perfect_model(), steps=300))
    assert as_json == typed and typed.components["recovery"] > 0


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


# -------------------------------------------------- eq. (1) pinned by hand-computed totals
# The expected numbers below are worked out by hand from the paper's equation (1) and the
# documented constants (weights 0.40/0.20/0.20/0.10/0.10; model parts topology 0.25,
# objects 0.25, states 0.15, affordances 0.10, queries 0.25; DETECT_WINDOW 30 steps after
# the first observable effect; FALSE_ALARM_COST 0.5), never read from ``_score``: moving
# any of them must fail a test here.
_LOCKED_GT = truth(doors=[d.model_copy(update={"state": "locked"}) if d.id == 2 else d
                          for d in GT.doors])
_LOCKED_FINAL = WorldModel.model_validate({"doors": [{"id": 2, "state": "locked"}]})


def _locked_model() -> WorldModel:
    """The perfect model of the house after door 2 locked."""
    doc = perfect_model().model_dump()
    doc["doors"][1]["state"] = "locked"
    return WorldModel.model_validate(doc)


def _card_of(o: Track1Outcome, *, snapshot: WorldModel | None, final: WorldModel | None,
             log: list[LogRecord] | None = None, steps: int = 100,
             invalid: int = 0) -> ScoreCard:
    """The card of ``o`` with separate exploration snapshot and final model."""
    files: dict[str, Any] = {"episode_log.jsonl": log or []}
    if final is not None:
        files["world_model.json"] = final
    return load_track("track1").score(ScoringInput(
        scenario=Scenario(track="track1", split="standard", seed=1),
        status=EpisodeStatus.COMPLETED, end_reason="completed",
        stages_reached=("exploration", "planning", "execution"),
        outcome=o, files=files,
        snapshots={"exploration": {"world_model.json": snapshot}} if snapshot else {},
        steps=steps, invalid_actions=invalid, protocol_errors=0,
        stage_budgets_s=granted_budgets(load_track("track1").stages())))


def test_the_constants_are_the_papers() -> None:
    assert _score.WEIGHTS == {"task": 0.40, "model": 0.20, "recovery": 0.20,
                              "efficiency": 0.10, "safety": 0.10}
    assert _score.MODEL_PARTS == {"topology": 0.25, "objects": 0.25, "states": 0.15,
                                  "affordances": 0.10, "queries": 0.25}
    assert (_score.DETECT_WINDOW, _score.FALSE_ALARM_COST) == (30, 0.5)


def test_equation_1_on_an_episode_with_every_component_different() -> None:
    """A door-lock episode, completed, with a partial exploration model.

    task = 0.6 × 1 (success) + 0.4 × 4/4 subgoals = 1.0
    model parts (exploration snapshot against the 3-room house):
      topology: 2 of the 3 edges, nothing wrong: F1 = 2·2 / (2 + 3) = 0.8
      objects: 3 of the 5, all right: F1 = 2·3 / (3 + 5) = 0.75
      states: doors 1 and 3 and container 11 right, door 2 and container 10 missing: 3/5 = 0.6
      affordances: (30, wipe) only, of 2: F1 = 2·1 / (1 + 2) = 2/3
      queries: q0, q1, q5 right of 6: 0.5
      model = 0.25·0.8 + 0.25·0.75 + 0.15·0.6 + 0.10·2/3 + 0.25·0.5
            = 0.2 + 0.1875 + 0.09 + 0.0666… + 0.125 = 0.669166…
    recovery: the lock at step 100 (effect 105); claims at 50 (before it: a false alarm)
      and 110 (in the window): detected = 1 × (1 − 0.5 × 1) = 0.5; the final model shows
      door 2 locked: updated = 1; completed = 1 → (0.5 + 1 + 1) / 3 = 5/6
    efficiency: SPL 8 / 16 = 0.5, × (1 − 10 / 40 redundant) = 0.375
    safety: bad = 5 invalid + 0.5 × 4 collisions = 7 over 100 steps: task × (1 − 14/100)
      = 0.86
    total = 0.40·1 + 0.20·0.669166… + 0.20·5/6 + 0.10·0.375 + 0.10·0.86
          = 0.4 + 0.133833… + 0.166666… + 0.0375 + 0.086 = 0.824
    """
    snapshot = WorldModel.model_validate({
        "connections": [{"rooms": (0, 1), "door": 1}, {"rooms": (1, 2), "door": 2}],
        "objects": [{"id": i, "category": c, "room": r, "position": xy}
                    for i, _, c, _, r, xy in _OBJECTS[:3]],
        "doors": [{"id": 1, "state": "open"}, {"id": 3, "state": "open"}],
        "containers": [{"id": 11, "state": "open"}],
        "affordances": [{"tool": 30, "affordance": "wipe"}],
    })
    o = outcome(planned_exception=_planned("door_lock"), exception=_exc("door_lock", 2),
                gt_final=_LOCKED_GT, queries=graded({k: RIGHT[k] for k in ("q0", "q1", "q5")}),
                execution={"steps": 40, "redundant": 10, "reference_length": 8.0,
                           "path_at_success": 16.0}, collisions=4)
    card = _card_of(o, snapshot=snapshot, final=_LOCKED_FINAL,
                    log=_log((50, "door_lock"), (110, "door_lock")), invalid=5)
    assert card.components == pytest.approx({
        "task": 1.0, "model": 0.6691666666666667, "recovery": 5 / 6, "efficiency": 0.375,
        "safety": 0.86})
    assert card.total == pytest.approx(0.824)
    assert card.metrics["model_verification"] == pytest.approx(0.6691666666666667)
    assert card.metrics["recovery_detected"] == pytest.approx(0.5)


def test_equation_1_on_a_failed_episode_that_made_progress() -> None:
    """No exception; the mug picked and the fridge reached, not opened nor placed; an empty
    model with every query right.

    task = 0.6 × 0 + 0.4 × 2/4 = 0.2
    model = 0.25 × 1 (queries only) = 0.25
    recovery (no exception): completing the task without a false alarm: 0
    efficiency: 0 (not completed)
    safety = 0.2 × (1 − 2 × 10 / 100) = 0.16 (10 invalid actions)
    total = 0.40·0.2 + 0.20·0.25 + 0 + 0 + 0.10·0.16 = 0.08 + 0.05 + 0.016 = 0.146
    """
    o = outcome(success=False, goals=[{"subgoals": {"picked": 3, "reached": 9,
                                                    "opened": None, "placed": None},
                                       "done": False}])
    card = _card_of(o, snapshot=WorldModel(), final=None, invalid=10)
    assert card.components == pytest.approx({"task": 0.2, "model": 0.25, "recovery": 0.0,
                                             "efficiency": 0.0, "safety": 0.16})
    assert card.total == pytest.approx(0.146)


_ALL_RIGHT_BUT = {
    # One part of the exploration model right, the rest empty: its weight alone.
    "topology": ({"connections": [{"rooms": c, "door": d}
                                  for c, d in (((0, 1), 1), ((1, 2), 2), ((0, 2), 3))]},
                 0.25),
    "objects": ({"objects": [{"id": i, "category": c, "room": r, "position": xy}
                             for i, _, c, _, r, xy in _OBJECTS]}, 0.25),
    "states": ({"doors": [{"id": 1, "state": "open"}, {"id": 2, "state": "closed"},
                          {"id": 3, "state": "open"}],
                "containers": [{"id": 10, "state": "closed"}, {"id": 11, "state": "open"}]},
               0.15),
    "affordances": ({"affordances": [{"tool": 30, "affordance": "wipe"},
                                     {"tool": 31, "affordance": "wipe"}]}, 0.10),
}


@pytest.mark.parametrize("part", [*_ALL_RIGHT_BUT, "queries"])
def test_each_model_part_carries_its_documented_weight(part: str) -> None:
    """A completed clean episode (task, recovery, efficiency, safety all 1) whose model
    earns one part only: model = that part's weight w, total = 0.40 + 0.20 w + 0.20 + 0.10
    + 0.10 = 0.8 + 0.2 w (topology, objects, queries 0.85; states 0.83; affordances 0.82)."""
    doc, weight = _ALL_RIGHT_BUT.get(part, ({}, 0.25))
    o = outcome(queries=graded(RIGHT if part == "queries" else {}))
    card = _card_of(o, snapshot=WorldModel.model_validate(doc), final=None)
    assert card.components["model"] == pytest.approx(weight)
    assert card.total == pytest.approx({"topology": 0.85, "objects": 0.85, "states": 0.83,
                                        "affordances": 0.82, "queries": 0.85}[part])


@pytest.mark.parametrize(("effect", "claim", "total"), [
    # A completed door-lock episode, perfect otherwise (task, model, efficiency, safety 1,
    # the final model shows the lock): total = 0.8 + 0.20 × (detected + 1 + 1) / 3.
    (100, 130, 1.0),  # effect at the lock's step 100: 100 + 30 = 130 is the last step
    (100, 131, 0.8 + 0.2 * 2 / 3),  # 31 steps after the effect: missed → 0.9333…
    (105, 135, 1.0),  # the window runs from the first observable effect (105 + 30)
    (105, 136, 0.8 + 0.2 * 2 / 3),
    (100, 99, 0.8 + 0.2 * 2 / 3),  # before the exception: not a detection
])
def test_detection_window_is_30_steps_after_the_effect(effect: int, claim: int,
                                                       total: float) -> None:
    o = outcome(planned_exception=_planned("door_lock"),
                exception=_exc("door_lock", 2, step=100, effect=effect), gt_final=_LOCKED_GT)
    model = _locked_model()
    card = _card_of(o, snapshot=perfect_model(), final=model, log=_log((claim, "door_lock")),
                    steps=300)
    assert card.total == pytest.approx(total)


@pytest.mark.parametrize(("false_alarms", "recovery", "total"), [
    # With the exception detected in time and the model updated, each false alarm (a claim
    # of another type) takes 0.5 off the detection: recovery = (1 − 0.5 n + 1 + 1) / 3.
    (0, 1.0, 1.0),
    (1, 2.5 / 3, 0.8 + 0.2 * 2.5 / 3),  # 0.9666…
    (2, 2 / 3, 0.8 + 0.2 * 2 / 3),  # 1 − 2 × 0.5 = 0: 0.9333…
    (3, 2 / 3, 0.8 + 0.2 * 2 / 3),  # floor 0, never negative
])
def test_false_alarms_cost_half_a_detection_each(false_alarms: int, recovery: float,
                                                 total: float) -> None:
    o = outcome(planned_exception=_planned("door_lock"), exception=_exc("door_lock", 2),
                gt_final=_LOCKED_GT)
    model = _locked_model()
    claims = [(110, "door_lock")] + [(111 + k, "tool_substitution")
                                     for k in range(false_alarms)]
    card = _card_of(o, snapshot=perfect_model(), final=model, log=_log(*claims))
    assert card.components["recovery"] == pytest.approx(recovery)
    assert card.total == pytest.approx(total)


@pytest.mark.parametrize(("false_alarms", "total"), [
    # Without an exception recovery is completion × (1 − 0.5 × false alarms), floor 0;
    # everything else perfect: total = 0.8 + 0.20 × recovery.
    (0, 1.0), (1, 0.9), (2, 0.8), (3, 0.8)])
def test_false_alarms_without_an_exception(false_alarms: int, total: float) -> None:
    card = _card_of(outcome(), snapshot=perfect_model(), final=perfect_model(),
                    log=_log(*[(10 + k, "door_lock") for k in range(false_alarms)]))
    assert card.total == pytest.approx(total)
