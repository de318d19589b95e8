"""``Track2``: one-demonstration rapid adaptation (paper §IV, DESIGN §6).

Stages (Table V, official budgets): ``demonstration`` 5 min, ``parsing`` 20 min (nothing
moves), ``execution`` 30 min with up to three attempts (see ``_episode``). The packet is
written by ``write_inputs`` into the read-only input folder (``/input/demo`` in the
container). Splits: ``standard`` (difficulty 0.4) and ``challenge`` (0.8); families mix by
seed. Files: ``task_model.json`` and ``episode_log.jsonl``, both required. Score: eq. (3),
see ``_scoring``. Leaderboard: Table VII's columns; the average is the mean over instances
(the paper's ranking rule), which equals Table VII's mean over families when families are
equally represented, as they are over consecutive seeds.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from plugins._base import (
    Column,
    FileRule,
    Scenario,
    ScoringInput,
    TrackPlugin,
    _mean,
    resource_columns,
)
from plugins.track2 import _scoring
from plugins.track2._episode import DEMO_FOLDER, DEMONSTRATION, EXECUTION, PARSING, Track2Episode
from plugins.track2._scenario import scenario_params
from schemas import EpisodeResult, ScoreCard, TaskModel
from simhost._episode import StageSpec, TrackEpisode

FAMILY_COLUMNS = (("insertion", "Insertion"), ("rotation", "Rotation"), ("assembly", "Assembly"),
                  ("opening", "Open/Close"), ("tool_use", "Tool Use"))


def _latest_model(data: ScoringInput) -> TaskModel | None:
    model = data.files.get("task_model.json")
    if isinstance(model, TaskModel):
        return model
    for stage in (EXECUTION, PARSING, DEMONSTRATION):
        snap = data.snapshots.get(stage, {}).get("task_model.json")
        if isinstance(snap, TaskModel):
            return snap
    return None


class Track2(TrackPlugin):
    name = "track2"
    title = "Track 2: one-demonstration rapid adaptation (manipulation bench, 5 families)"
    weights = dict(_scoring.WEIGHTS)
    files = {
        "task_model.json": FileRule(TaskModel),
        "episode_log.jsonl": FileRule(None, jsonl=True),
    }
    splits = {
        "standard": (0.5, {"difficulty": 0.4}),
        "challenge": (0.5, {"difficulty": 0.8}),
    }
    columns = (
        *(Column(k, t) for k, t in FAMILY_COLUMNS),
        Column("final", "Avg. Score"),
        Column("task_success", "Succ. %"),
        Column("task_model", "Task Model %"),
        Column("attempts", "Attempts", "{:.2f}", lower_is_better=True),
        Column("adapt_time_min", "Adapt. Time min", "{:.2f}", lower_is_better=True),
        Column("runtime_min", "Runtime min", "{:.1f}", lower_is_better=True),
    )
    tie_breaks = ("task_success", "task_model", "attempts", "adapt_time_min", "runtime_min")

    def stages(self) -> list[StageSpec]:
        return [
            StageSpec(DEMONSTRATION, budget_s=5 * 60.0, allows_motion=False,
                      description="receive one standardized expert demonstration"),
            StageSpec(PARSING, budget_s=20 * 60.0, allows_motion=False,
                      description="infer state variables, constraints and policy updates; "
                      "write task_model.json (nothing moves)"),
            StageSpec(EXECUTION, budget_s=30 * 60.0,
                      description="execute the task on the hidden instance, up to 3 attempts"),
        ]

    def make_scenario(
        self, *, seed: int, split: str, params: Mapping[str, Any], index: int | None = None
    ) -> Scenario:
        merged = {**self.splits.get(split, (1.0, {}))[1], **params}
        return Scenario(track=self.name, split=split, seed=seed,
                        params=scenario_params(seed, merged))

    def make_episode(self, scenario: Scenario) -> TrackEpisode:
        return Track2Episode(scenario)

    def write_inputs(self, scenario: Scenario, folder: Path) -> None:
        """The demonstration packet of the scenario's source, in ``folder/demo``."""
        from simhost.track2 import InstanceParams, write_demo_packet

        p = scenario.params
        write_demo_packet(folder / DEMO_FOLDER, InstanceParams.model_validate(p["source"]),
                          seed=int(p["demo_seed"]), frames=bool(p.get("demo_frames", True)))

    def score(self, data: ScoringInput) -> ScoreCard:
        from simhost.track2 import InstanceParams, task_truth

        p = data.scenario.params
        truth = task_truth(InstanceParams.model_validate(p["instance"]))
        o = data.outcome
        model = _latest_model(data)
        parts = _scoring.model_parts(model, truth)
        invalid = data.invalid_actions + data.protocol_errors
        components = {
            "success": float(bool(o.get("success"))),
            "adaptation": _scoring.adaptation(o),
            "generalization": _scoring.generalization(o, float(p.get("distance", 0.0))),
            "task_model": sum(parts.values()) / len(parts),
            "stability": _scoring.stability(o, invalid),
        }
        total = sum(self.weights[k] * v for k, v in components.items())
        family = str(p["family"])
        metrics = {
            "task_success": components["success"],
            "task_model": components["task_model"],
            "attempts": float(_scoring.attempts_needed(o)),
            "adapt_time_min": float(o.get("adapt_time_s") or 0.0) / 60.0,
            "progress": 1.0 if o.get("success") else float(o.get("best_progress") or 0.0),
            "distance": float(p.get("distance", 0.0)),
            "invalid_actions": float(invalid),
            f"family_{family}": 1.0,
            **{f"task_model_{k}": v for k, v in parts.items()},
        }
        tried = len(o.get("attempts", []))
        notes = [f"family={family}", f"attempts={tried}, success at "
                 f"{o.get('success_attempt') or 'none'}"]
        if model is None:
            notes.append("no valid task_model.json")
        elif model.family != family:
            notes.append(f"task model names family {model.family!r}, the task is {family!r}")
        return ScoreCard(track=self.name, total=min(1.0, max(0.0, total)),
                         components=components, weights=dict(self.weights), metrics=metrics,
                         notes=tuple(notes))

    def picture(self, episode_dir: Path, out: Path | None = None) -> Path:
        """The successful (else the last) attempt beside the demonstration."""
        from plugins.track2._picture import attempt_png

        return attempt_png(episode_dir, path=out)

    def summarize(self, results: Sequence[EpisodeResult]) -> dict[str, float | None]:
        """Table VII's row: per-family and average scores (0–100), success and task-model
        percentages, mean attempts needed, adaptation and run time in minutes."""
        row: dict[str, float | None] = {}
        for fam, _ in FAMILY_COLUMNS:
            row[fam] = _mean([100.0 * r.score.total for r in results
                              if r.score.metrics.get(f"family_{fam}")])
        by_split: dict[str, list[float]] = {}
        for r in results:
            by_split.setdefault(r.split, []).append(100.0 * r.score.total)
        row.update({s: _mean(v) for s, v in by_split.items()})
        row["final"] = _mean([100.0 * r.score.total for r in results])

        def metric(key: str, scale: float = 1.0) -> float | None:
            vals = [r.score.metrics[key] for r in results if key in r.score.metrics]
            return None if not vals else scale * sum(vals) / len(vals)

        row["task_success"] = metric("task_success", 100.0)
        row["task_model"] = metric("task_model", 100.0)
        row["attempts"] = metric("attempts")
        row["adapt_time_min"] = metric("adapt_time_min")
        row["invalid_actions"] = metric("invalid_actions")
        row.update(resource_columns(results))
        return row
