"""Track 2's score (eq. 3) on hand-built cases: it pays only for what was achieved."""

from __future__ import annotations

import math
from typing import Any

import pytest

from plugins import Scenario, ScoringInput, granted_budgets, load_track
from plugins.track2 import WEIGHTS, model_parts, model_score
from plugins.track2._outcome import AttemptRecord, Track2Outcome
from plugins.track2._scoring import MODEL_WEIGHTS, OFFICIAL_ADAPT_S, close
from schemas import EpisodeResult, EpisodeStats, NamedItem, Precondition, ScoreCard, TaskModel
from schemas._files import StateVariable, SuccessCriterion
from schemas._result import EpisodeStatus
from simhost.worlds.track2 import TaskTruth, task_truth

TRACK = load_track("track2")


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    s = TRACK.make_scenario(seed=0, split="standard", params={"demo_frames": False}, index=0)
    assert s.params["family"] == "insertion"
    return s


def _far(s: Scenario, distance: float = 1.0) -> Scenario:
    hidden = TRACK.hidden(s).model_copy(update={"distance": distance})
    return TRACK.new_scenario(seed=s.seed, split=s.split, hidden=hidden)


def truth_of(s: Scenario) -> TaskTruth:
    hidden = TRACK.hidden(s)
    return task_truth(hidden.instance, hidden.bench)


def model_from_truth(truth: TaskTruth, **changes: Any) -> TaskModel:
    m = TaskModel(
        family=truth.family,
        stages=list(truth.stages),
        variables=[StateVariable(**v.model_dump()) for v in truth.state_variables],
        constraints=[NamedItem(name=c.name, value=c.value) for c in truth.constraints],
        preconditions=[Precondition(stage=k, requires=list(v))
                       for k, v in truth.preconditions.items()],
        success_criteria=[SuccessCriterion(**c.model_dump()) for c in truth.success],
    )
    return m.model_copy(update=changes)


def outcome(*, won: int | None = 1, tried: int | None = None, progress: float = 1.0,
            start: float = 0.0, steps: int = 100, adapt_s: float = 0.0,
            **stats: Any) -> Track2Outcome:
    n = tried if tried is not None else (won or 3)
    attempts = [AttemptRecord(index=k, steps=steps // n, success=k == won,
                              start_progress=start, peak_progress=1.0 if k == won else progress)
                for k in range(1, n + 1)]
    return Track2Outcome(attempts=attempts, max_attempts=3, success=won is not None,
                         success_attempt=won, adapt_time_s=adapt_s, steps=steps, **stats)


def score(s: Scenario, o: Track2Outcome, model: TaskModel | None = None, *,
          snapshots: dict[str, Any] | None = None, invalid: int = 0,
          budgets: dict[str, float] | None = None) -> ScoreCard:
    files = {} if model is None else {"task_model.json": model}
    return TRACK.score(ScoringInput(
        scenario=s, status=EpisodeStatus.COMPLETED, end_reason="success", stages_reached=(),
        outcome=o, files=files, snapshots=snapshots or {},
        steps=o.steps if isinstance(o, Track2Outcome) else 0,
        invalid_actions=invalid, protocol_errors=0,
        stage_budgets_s=budgets or granted_budgets(TRACK.stages())))


def test_weights_are_equation_3() -> None:
    assert WEIGHTS == {"success": 0.45, "adaptation": 0.20, "generalization": 0.15,
                       "task_model": 0.10, "stability": 0.10}


def test_equation_3_on_a_success_at_the_second_attempt(scenario: Scenario) -> None:
    """Hand-computed: success at attempt 2 of 3, 375 s of adaptation against the official
    25 min, a model with the public vocabulary only, one drop.

    success = 1
    adaptation = 0.6 × (3 − 2 + 1) / 3 + 0.4 × (1 − 375 / 1500) = 0.4 + 0.3 = 0.7
    generalization = 1 (success)
    task_model = 0.1 stages + 0.1 variables + 0.1 preconditions (constraints and success
      criteria, 0.35 each, left out) = 0.3
    stability = 1 × (1 − 0.25 × 1 drop) = 0.75
    total = 0.45 × 1 + 0.20 × 0.7 + 0.15 × 1 + 0.10 × 0.3 + 0.10 × 0.75
          = 0.45 + 0.14 + 0.15 + 0.03 + 0.075 = 0.845
    """
    model = model_from_truth(truth_of(scenario), constraints=[], success_criteria=[])
    card = score(scenario, outcome(won=2, adapt_s=375.0, drops=1), model)
    assert card.components == pytest.approx({"success": 1.0, "adaptation": 0.7,
                                             "generalization": 1.0, "task_model": 0.3,
                                             "stability": 0.75})
    assert card.total == pytest.approx(0.845)


def test_equation_3_on_a_failure_that_made_progress(scenario: Scenario) -> None:
    """Hand-computed: no success in 3 attempts, the best from 0.2 to 0.6 of the way, a
    perfect task model, 10 jerky steps of 100.

    success = 0, adaptation = 0 (no success)
    generalization = (0.6 − 0.2) / (1 − 0.2) = 0.5
    task_model = 1
    stability = 0.5 × (1 − 10 / 100) = 0.45
    total = 0.15 × 0.5 + 0.10 × 1 + 0.10 × 0.45 = 0.075 + 0.1 + 0.045 = 0.22
    """
    o = outcome(won=None, progress=0.6, start=0.2, jerk_steps=10)
    card = score(scenario, o, model_from_truth(truth_of(scenario)))
    assert card.components == pytest.approx({"success": 0.0, "adaptation": 0.0,
                                             "generalization": 0.5, "task_model": 1.0,
                                             "stability": 0.45})
    assert card.total == pytest.approx(0.22)


def test_perfect_episode_scores_one(scenario: Scenario) -> None:
    s = _far(scenario)
    card = score(s, outcome(won=1), model_from_truth(truth_of(s)))
    assert card.components == {"success": 1.0, "adaptation": 1.0, "generalization": 1.0,
                               "task_model": 1.0, "stability": 1.0}
    assert card.total == pytest.approx(1.0)
    assert card.metrics["task_success"] == 1.0 and card.metrics["attempts"] == 1.0
    assert card.metrics["family_insertion"] == 1.0


def test_empty_episode_scores_zero(scenario: Scenario) -> None:
    o = {"attempts": [], "max_attempts": 3, "success": False, "success_attempt": None,
         "adapt_time_s": 0.0, "steps": 0}
    card = score(scenario, o)
    assert card.total == 0.0 and set(card.components.values()) == {0.0}
    assert card.metrics["attempts"] == 3.0  # a failure needed every attempt allowed
    assert "no valid task_model.json" in card.notes


def test_wrong_or_missing_family_makes_the_model_worthless(scenario: Scenario) -> None:
    truth = truth_of(scenario)
    assert model_score(model_from_truth(truth), truth) == pytest.approx(1.0)
    assert model_score(model_from_truth(truth, family="rotation"), truth) == 0.0
    assert model_score(model_from_truth(truth, family=None), truth) == 0.0
    card = score(scenario, outcome(), model_from_truth(truth, family="assembly"))
    assert card.components["task_model"] == 0.0
    assert any("'assembly'" in n for n in card.notes)


def test_partial_and_padded_models(scenario: Scenario) -> None:
    truth = truth_of(scenario)
    only_stages = TaskModel(family="insertion", stages=list(truth.stages))
    assert model_parts(only_stages, truth)["stages"] == 1.0
    assert model_score(only_stages, truth) == pytest.approx(MODEL_WEIGHTS["stages"])
    vocabulary = model_from_truth(truth, constraints=[], success_criteria=[])
    assert model_score(vocabulary, truth) == pytest.approx(0.3), \
        "the public vocabulary alone earns 30 %: values must be inferred"
    shuffled = model_from_truth(truth, stages=list(reversed(truth.stages)))
    assert model_parts(shuffled, truth)["stages"] == pytest.approx(1 / len(truth.stages))
    perfect = model_from_truth(truth)
    padded = perfect.model_copy(update={"constraints": perfect.constraints + [
        NamedItem(name=f"guess_{k}", value=k) for k in range(10)]})
    assert model_parts(padded, truth)["constraints"] < 0.5 < model_parts(perfect, truth)[
        "constraints"]
    # A value a little off earns part of its credit; a wrong op none.
    off = [c.model_copy(update={"value": c.value * 1.1}) if isinstance(c.value, float) else c
           for c in perfect.success_criteria]
    assert 0.5 < model_parts(perfect.model_copy(update={"success_criteria": off}),
                             truth)["success"] < 1.0
    wrong_op = [c.model_copy(update={"op": "<="}) if c.op == ">=" else c
                for c in perfect.success_criteria]
    assert model_parts(perfect.model_copy(update={"success_criteria": wrong_op}),
                       truth)["success"] < 1.0


def test_values_compare_by_type() -> None:
    assert close(True, True) == 1.0 and close(1, True) == 0.0 and close(True, 1) == 0.0
    assert close("Square", "square") == 1.0 and close("round", "square") == 0.0
    assert close(0.004, 0.004) == 1.0 and 0.0 < close(0.0045, 0.004) < 1.0
    assert close(float("nan"), 0.004) == 0.0 and close("0.004", 0.004) == 0.0
    assert close([0.5, 0.7], [0.5, 0.7]) == 1.0 and close([0.5], [0.5, 0.7]) == 0.0


def test_success_at_the_first_attempt_beats_the_third(scenario: Scenario) -> None:
    s = _far(scenario)
    model = model_from_truth(truth_of(s))
    first, third = score(s, outcome(won=1), model), score(s, outcome(won=3), model)
    assert first.components["adaptation"] == pytest.approx(1.0)
    assert third.components["adaptation"] == pytest.approx(0.6 / 3 + 0.4)
    assert first.total - third.total == pytest.approx(0.20 * 0.4)
    assert (first.metrics["attempts"], third.metrics["attempts"]) == (1.0, 3.0)
    slow = score(s, outcome(won=1, adapt_s=OFFICIAL_ADAPT_S / 2), model)
    assert slow.components["adaptation"] == pytest.approx(0.6 + 0.4 * 0.5)
    assert slow.metrics["adapt_time_min"] == pytest.approx(OFFICIAL_ADAPT_S / 120)


def test_adaptation_time_counts_against_the_budget_granted(scenario: Scenario) -> None:
    model = model_from_truth(truth_of(scenario))
    granted = {"demonstration": 30.0, "parsing": 120.0, "execution": 180.0}  # scaled 0.1
    quick = score(scenario, outcome(won=1, adapt_s=75.0), model, budgets=granted)
    assert quick.components["adaptation"] == pytest.approx(0.6 + 0.4 * 0.5)
    official = score(scenario, outcome(won=1, adapt_s=75.0), model)
    assert official.components["adaptation"] == pytest.approx(0.6 + 0.4 * (1 - 75 / 1500))


def test_generalization_is_progress_from_the_start_whatever_the_distance(
        scenario: Scenario) -> None:
    o = outcome(won=None, progress=0.6, start=0.2)
    far, near = score(_far(scenario, 0.9), o), score(_far(scenario, 0.0), o)
    assert far.components["success"] == far.components["adaptation"] == 0.0
    assert far.components["generalization"] == pytest.approx((0.6 - 0.2) / 0.8)
    assert near.components == far.components, "the same outcome, the same score"
    assert far.metrics["distance"] == 0.9
    still = score(scenario, outcome(won=None, progress=0.2, start=0.2))
    assert still.components["generalization"] == 0.0 and still.components["stability"] == 0.0


def test_stability_penalties(scenario: Scenario) -> None:
    clean = score(scenario, outcome(steps=100)).components["stability"]
    assert clean == 1.0
    halfway = score(scenario, outcome(won=None, progress=0.5, steps=100))
    assert halfway.components["stability"] == pytest.approx(0.5), "scaled by progress"
    cases = {"drops": {"drops": 1}, "force": {"excess_force_steps": 10},
             "limits": {"limit_steps": 10}, "jerk": {"jerk_steps": 10},
             "warnings": {"sim_warnings": 2}}
    for name, stats in cases.items():
        got = score(scenario, outcome(steps=100, **stats)).components["stability"]
        assert 0.0 < got < 1.0, name
    invalid = score(scenario, outcome(steps=100), invalid=25).components["stability"]
    assert invalid == pytest.approx(1 - 2 * 25 / 125)
    assert score(scenario, outcome(steps=100, drops=5)).components["stability"] == 0.0


def test_the_latest_valid_snapshot_stands_in_for_a_missing_model(scenario: Scenario) -> None:
    truth = truth_of(scenario)
    snaps = {"parsing": {"task_model.json": model_from_truth(truth)}}
    card = score(scenario, outcome(), None, snapshots=snaps)
    assert card.components["task_model"] == pytest.approx(1.0)


def _result(family: str, total: float, *, won: bool, attempts: float, model: float,
            split: str = "standard") -> EpisodeResult:
    card = ScoreCard(track="track2", total=total, components={}, weights={},
                     metrics={"task_success": float(won), "task_model": model,
                              "attempts": attempts, "adapt_time_min": 1.0,
                              f"family_{family}": 1.0})
    return EpisodeResult(episode="e", track="track2", split=split, image="i", runtime="local",
                         status=EpisodeStatus.COMPLETED, score=card,
                         stats=EpisodeStats(wall_s=120.0), started_at=0.0, finished_at=1.0)


def test_summarize_has_table_vii_layout() -> None:
    results = [_result("insertion", 0.8, won=True, attempts=1, model=0.9),
               _result("insertion", 0.4, won=False, attempts=3, model=0.5, split="challenge"),
               _result("tool_use", 0.3, won=False, attempts=3, model=0.2)]
    row = TRACK.summarize(results)
    assert [c.title for c in TRACK.columns][:10] == [
        "Insertion", "Rotation", "Assembly", "Open/Close", "Tool Use", "Avg. Score", "Succ. %",
        "Task Model %", "Attempts", "Adapt. Time min"]
    assert {c.key for c in TRACK.columns} <= set(row)
    assert row["insertion"] == pytest.approx(60.0) and row["tool_use"] == pytest.approx(30.0)
    assert row["rotation"] is None
    assert row["final"] == pytest.approx(45.0), "the mean over families, as in Table VII"
    assert row["task_success"] == pytest.approx(100 / 3)
    assert row["task_model"] == pytest.approx(160 / 3)
    assert row["attempts"] == pytest.approx(7 / 3)
    assert row["standard"] == pytest.approx(55.0) and row["challenge"] == pytest.approx(40.0)
    assert row["runtime_min"] == pytest.approx(2.0)
    lower = {c.key for c in TRACK.columns if c.lower_is_better}
    assert TRACK.tie_breaks == ("task_success", "task_model", "attempts", "adapt_time_min",
                                "runtime_min")
    assert {"attempts", "adapt_time_min", "runtime_min"} <= lower
    assert math.isclose(sum(TRACK.weights.values()), 1.0)


def test_an_outcome_given_as_json_scores_as_the_model(scenario: Scenario) -> None:
    o = outcome(won=2, adapt_s=300.0, drops=1)
    as_json = score(scenario, o.model_dump(mode="json"))  # type: ignore[arg-type]
    assert as_json == score(scenario, o)
    assert as_json.components["adaptation"] > 0 and as_json.metrics["attempts"] == 2.0


def test_an_episode_without_outcome_scores_as_one_where_nothing_happened(
        scenario: Scenario) -> None:
    for nothing in (None, {}):
        card = score(scenario, nothing)  # type: ignore[arg-type]
        assert card.total == 0.0 and card.metrics["attempts"] == 3.0
