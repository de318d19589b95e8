"""Track 1 scoring on hand-built ground truths: every component, perfect and empty models,
recovery with and without an exception, the leaderboard row (Table IV) and tie-breaks."""

from __future__ import annotations

import math
from typing import Any

import pytest

from plugins import Scenario, ScoringInput, load_track
from plugins.track1 import _score
from plugins.track1._queries import score_answer, truth_of
from schemas import EpisodeResult, EpisodeStats, LogRecord, ScoreCard, WorldModel
from schemas._result import EpisodeStatus

# A three-room house: 0 kitchen, 1 hallway, 2 storage; doors 1 (0-1), 2 (1-2), 3 (0-2).
GT: dict[str, Any] = {
    "rooms": [{"id": 0, "type": "kitchen"}, {"id": 1, "type": "hallway"},
              {"id": 2, "type": "storage"}],
    "edges": [{"rooms": [0, 1], "door": 1}, {"rooms": [1, 2], "door": 2},
              {"rooms": [0, 2], "door": 3}],
    "doors": [{"id": 1, "state": "open"}, {"id": 2, "state": "closed"},
              {"id": 3, "state": "open"}],
    "containers": [{"id": 10, "state": "closed", "room": 0},
                   {"id": 11, "state": "open", "room": 0}],
    "furniture": [],
    "objects": [
        {"id": 20, "kind": "object", "category": "mug", "colour": "red", "room": 0,
         "position": [1.0, 1.0, 0.9]},
        {"id": 21, "kind": "object", "category": "apple", "colour": "green", "room": 2,
         "position": [5.0, 1.0, 0.9]},
        {"id": 30, "kind": "tool", "category": "sponge", "colour": "yellow", "room": 1,
         "position": [3.0, 4.0, 0.9]},
        {"id": 31, "kind": "tool", "category": "cloth", "colour": "blue", "room": 2,
         "position": [5.5, 2.0, 0.9]},
    ],
    "tools": [{"id": 30, "category": "sponge", "affordances": ["wipe"], "available": True},
              {"id": 31, "category": "cloth", "affordances": ["wipe"], "available": True}],
    "affordances": {"wipe": [30, 31], "cut": [], "water": []},
}


def perfect_model(gt: dict[str, Any] = GT) -> WorldModel:
    return WorldModel.model_validate({
        "rooms": gt["rooms"],
        "connections": [{"rooms": e["rooms"], "door": e["door"]} for e in gt["edges"]],
        "doors": [{"id": d["id"], "state": d["state"]} for d in gt["doors"]],
        "containers": [{"id": c["id"], "state": c["state"]} for c in gt["containers"]],
        "objects": [{"id": o["id"], "category": o["category"], "room": o["room"],
                     "position": o["position"][:2]} for o in gt["objects"]],
        "affordances": [{"tool": t["id"], "affordance": a} for t in gt["tools"]
                        for a in t["affordances"]],
    })


QUERIES = [
    {"id": "q0", "kind": "object_room", "subject": 20},
    {"id": "q1", "kind": "door_state", "subject": 2},
    {"id": "q2", "kind": "room_neighbours", "subject": 0},
    {"id": "q3", "kind": "container_state", "subject": 11},
    {"id": "q4", "kind": "tools_for", "subject": "wipe"},
]


def graded(answers: dict[str, Any], sent: set[str] | None = None) -> list[dict[str, Any]]:
    out = []
    for q in QUERIES:
        truth = truth_of(q["kind"], q["subject"], GT)
        ok = sent is None or q["id"] in sent
        out.append({**q, "sent": ok, "truth": truth, "answer": answers.get(q["id"]),
                    "score": score_answer(q["kind"], answers.get(q["id"]), truth) if ok else 0.0})
    return out


def test_the_truth_of_each_query_kind() -> None:
    assert [truth_of(q["kind"], q["subject"], GT) for q in QUERIES] == [
        0, "closed", [1, 2], "open", [30, 31]]


def test_a_perfect_model_scores_one_on_every_part() -> None:
    right = {"q0": 0, "q1": "closed", "q2": [2, 1], "q3": "open", "q4": [31, 30]}
    parts = _score.model_parts(perfect_model(), GT, graded(right))
    assert parts == {"queries": 1.0, "topology": 1.0, "objects": 1.0, "states": 1.0,
                     "affordances": 1.0}
    assert math.isclose(sum(_score.MODEL_PARTS[k] * v for k, v in parts.items()), 1.0)


def test_an_empty_or_missing_model_scores_zero() -> None:
    empty = WorldModel()
    parts = _score.model_parts(empty, GT, graded({}))
    assert parts == {"queries": 0.0, "topology": 0.0, "objects": 0.0, "states": 0.0,
                     "affordances": 0.0}
    assert all(v == 0.0 for v in _score.model_parts(None, GT, []).values())
    assert all(v == 0.0 for v in _score.model_parts(perfect_model(), None, []).values())


def test_partial_models_score_in_between() -> None:
    doc = perfect_model().model_dump()
    doc["connections"] = doc["connections"][:2] + [{"rooms": [1, 5]}]  # 2 of 3 right, 1 wrong
    doc["objects"][0]["position"] = [1.4, 1.0]  # within the 0.5 m tolerance
    doc["objects"][1]["position"] = [6.0, 1.0]  # 1 m off: no match
    doc["objects"][2]["room"] = "1"  # ids as strings are fine
    doc["doors"][1]["state"] = "open"  # wrong
    del doc["containers"][0]  # missing: wrong
    doc["affordances"].append({"tool": 20, "affordance": "cut"})  # a mug does not cut
    m = WorldModel.model_validate(doc)
    assert math.isclose(_score.topology(m, GT), 2 * 2 / (3 + 3))
    assert math.isclose(_score.inventory(m, GT), 2 * 3 / (4 + 4))
    assert math.isclose(_score.states(m, GT), 3 / 5)
    assert math.isclose(_score.affordances(m, GT), 2 * 2 / (3 + 2))


def test_answers_are_graded_by_kind_and_unsent_queries_count_as_wrong() -> None:
    assert score_answer("object_room", "0", 0) == 1.0
    assert score_answer("object_room", True, 1) == 0.0
    assert score_answer("door_state", " Closed ", "closed") == 1.0
    assert score_answer("room_neighbours", [1], [1, 2]) == pytest.approx(2 / 3)
    assert score_answer("tools_for", "30", [30]) == 0.0  # a list is required
    assert score_answer("tools_for", [], []) == 1.0
    right = {"q0": 0, "q1": "closed", "q2": [1, 2], "q3": "open", "q4": [30, 31]}
    only_two = graded(right, sent={"q0", "q1"})
    parts = _score.model_parts(perfect_model(), GT, only_two)
    assert parts["queries"] == pytest.approx(2 / 5)


# ------------------------------------------------------------------------ recovery
def _exc(kind: str, subject: int, step: int = 100, effect: int | None = 105) -> dict:
    return {"type": kind, "subject": subject, "step": step, "pose": [0.0, 0.0],
            "details": {}, "effect_step": effect}


def _log(*records: tuple[int, str]) -> list[LogRecord]:
    return [LogRecord(step=s, event="exception_detected", exception_type=t)  # type: ignore[arg-type]
            for s, t in records]


def test_recovery_detection_needs_the_right_type_in_the_window() -> None:
    outcome = {"exception": _exc("door_lock", 2), "success": True, "steps": 300,
               "gt_final": {**GT, "doors": [{"id": 2, "state": "locked"}]}}
    locked = WorldModel.model_validate({"doors": [{"id": 2, "state": "locked"}]})
    full = _score.recovery_parts(outcome, _log((110, "door_lock")), locked)
    assert full == {"detected": 1.0, "updated": 1.0, "completed": 1.0}
    late = _score.recovery_parts(outcome, _log((105 + _score.DETECT_WINDOW + 1, "door_lock")),
                                 locked)
    assert late is not None and late["detected"] == 0.0
    wrong = _score.recovery_parts(outcome, _log((110, "object_relocation")), locked)
    assert wrong is not None and wrong["detected"] == 0.0
    spam = _score.recovery_parts(outcome, _log((50, "door_lock"), (110, "door_lock"),
                                               (111, "tool_substitution")), locked)
    assert spam is not None and spam["detected"] == pytest.approx(1 - 2 * 0.25)
    stale = _score.recovery_parts(outcome, [], WorldModel())
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
    gt = {**GT, "tools": [{**t, "available": t["id"] != 30} for t in GT["tools"]]}
    outcome = {"exception": _exc(kind, subject), "success": False, "steps": 200, "gt_final": gt}
    ok = _score.recovery_parts(outcome, [], WorldModel.model_validate(updated))
    bad = _score.recovery_parts(outcome, [], WorldModel.model_validate(stale))
    assert ok is not None and ok["updated"] == 1.0
    assert bad is not None and bad["updated"] == 0.0
    # An empty model never counts as updated (no credit for knowing nothing).
    empty = _score.recovery_parts(outcome, [], WorldModel())
    assert empty is not None and empty["updated"] == 0.0


def test_no_exception_means_no_recovery_and_an_untriggered_one_counts_as_missed() -> None:
    assert _score.recovery_parts({"exception": None, "planned_exception": None}, [], None) is None
    skipped = {"exception": None, "planned_exception": "door_lock",
               "exception_skipped": "door_lock: the route crosses no door"}
    assert _score.recovery_parts(skipped, [], None) is None
    missed = {"exception": None, "planned_exception": "door_lock", "success": True}
    assert _score.recovery_parts(missed, [], None) == {
        "detected": 0.0, "updated": 0.0, "completed": 1.0}


# -------------------------------------------------------------------- whole cards
def _input(outcome: dict, *, model: WorldModel | None, log: list[LogRecord] | None = None,
           steps: int = 100, invalid: int = 0) -> ScoringInput:
    files: dict[str, Any] = {"episode_log.jsonl": log or []}
    if model is not None:
        files["world_model.json"] = model
    return ScoringInput(
        scenario=Scenario(track="track1", split="standard", seed=1),
        status=EpisodeStatus.COMPLETED, end_reason="completed",
        stages_reached=("exploration", "planning", "execution"), outcome=outcome, files=files,
        snapshots={"exploration": {"world_model.json": model}} if model else {},
        steps=steps, invalid_actions=invalid, protocol_errors=0)


def _outcome(**kw: Any) -> dict[str, Any]:
    right = {"q0": 0, "q1": "closed", "q2": [1, 2], "q3": "open", "q4": [30, 31]}
    base = {"started": True, "success": True, "planned_exception": None, "exception": None,
            "exception_skipped": None,
            "subgoals": {"picked": 10, "reached": 20, "opened": 21, "placed": 22},
            "queries": graded(right), "gt_exploration": GT, "gt_final": GT, "steps": 100,
            "execution": {"steps": 40, "redundant": 0, "reference_length": 10.0,
                          "path_at_success": 10.0},
            "collisions": 0, "deadlocks": 0, "sim_warnings": 0}
    return {**base, **kw}


def test_a_perfect_episode_without_exception_scores_one() -> None:
    card = load_track("track1").score(_input(_outcome(), model=perfect_model()))
    assert card.total == pytest.approx(1.0)
    assert "recovery" not in card.components
    assert sum(card.weights.values()) == pytest.approx(1.0)
    assert card.weights["task"] == pytest.approx(0.5)  # 0.40 / 0.80: spread in proportion
    assert card.metrics["task_success"] == 1.0 and card.metrics["model_verification"] == 1.0


def test_an_empty_episode_scores_zero() -> None:
    o = _outcome(success=False, subgoals={"picked": None, "placed": None}, queries=graded({}),
                 planned_exception="door_lock", execution={})
    card = load_track("track1").score(_input(o, model=None, steps=0))
    assert card.total == 0.0
    assert set(card.components) == set(_score.WEIGHTS)
    assert any("no valid world_model.json" in n for n in card.notes)


def test_task_efficiency_and_safety_components() -> None:
    o = _outcome(success=False, subgoals={"picked": 3, "reached": None, "placed": None},
                 execution={"steps": 40, "redundant": 10, "reference_length": 8.0,
                            "path_at_success": None}, collisions=4, deadlocks=1)
    card = load_track("track1").score(_input(o, model=perfect_model(), invalid=5))
    assert card.components["task"] == pytest.approx(0.4 / 3)
    assert card.components["efficiency"] == 0.0
    # bad = 5 invalid + 0.5 × 4 collisions + 5 × 1 deadlock = 12 over 100 steps.
    assert card.components["safety"] == pytest.approx(1 - 2 * 12 / 100)
    good = _outcome(execution={"steps": 40, "redundant": 10, "reference_length": 8.0,
                               "path_at_success": 16.0})
    assert _score.efficiency(good) == pytest.approx(0.5 * (1 - 10 / 40))


def test_an_exception_episode_counts_recovery_at_its_full_weight() -> None:
    exc = _exc("door_lock", 2)
    gt_final = {**GT, "doors": [{"id": 1, "state": "open"}, {"id": 2, "state": "locked"}]}
    o = _outcome(planned_exception="door_lock", exception=exc, gt_final=gt_final)
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
