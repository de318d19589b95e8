"""``Track2``: one-demonstration rapid adaptation (paper §IV, plugins/track2/README.md).

Stages (Table V, official budgets): ``demonstration`` 5 min, ``parsing`` 20 min (nothing
moves), ``execution`` 30 min with up to three attempts (see ``_episode``). The packet
(``eagc-demo/v2``) is written by ``write_inputs`` into the read-only input folder
(``/input/demo`` in the container). Splits (``simhost.worlds.track2.SPLITS``): the official
``standard`` and ``challenge`` (a robot's observation, a goal defined by the demonstration,
wide variation; the final score's splits) and the public ``dev`` (today's level, an extra
split); a campaign split of another name sets ``params.preset``. Families are balanced by
the episode's index within its split (``index mod 5``). Files: ``task_model.json`` and
``episode_log.jsonl``, both required. Score: eq. (3), see ``_scoring``. Leaderboard: Table
VII's columns; the average is the mean over families of each family's mean score, as in
Table VII.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from plugins._base import Scenario, ScoringInput, TrackPlugin
from plugins._files import EPISODE_LOG, FileRule
from plugins._leaderboard import Column, mean, resource_columns
from plugins._views import RecordedEpisode, StepPicture
from plugins.track2 import _scoring, _vocabulary
from plugins.track2._episode import DEMO_FOLDER, DEMONSTRATION, EXECUTION, PARSING, Track2Episode
from plugins.track2._outcome import Track2Outcome
from plugins.track2._picture import attempt_pictures, attempt_png, preview_png
from plugins.track2._scenario import Track2Scenario, make_track2_scenario
from schemas import EpisodeResult, ScoreCard, TaskModel, ignored_note
from simhost.host import StageSpec, TrackEpisode

FAMILY_COLUMNS = (("insertion", "Insertion"), ("rotation", "Rotation"), ("assembly", "Assembly"),
                  ("opening", "Open/Close"), ("tool_use", "Tool Use"))


def _latest_model(data: ScoringInput[Track2Scenario, Track2Outcome]) -> TaskModel | None:
    """The final task model, else the latest valid stage snapshot's."""
    found = (data.file("task_model.json", TaskModel),
             *(data.snapshot(stage, "task_model.json", TaskModel)
               for stage in (EXECUTION, PARSING, DEMONSTRATION)))
    return next((m for m in found if m is not None), None)


class Track2(TrackPlugin[Track2Scenario, Track2Outcome]):
    name = "track2"
    title = "Track 2: one-demonstration rapid adaptation (manipulation bench, 5 families)"
    weights = dict(_scoring.WEIGHTS)
    files = {
        "task_model.json": FileRule(TaskModel),
        EPISODE_LOG: FileRule(None, jsonl=True),
    }
    splits = {
        "standard": (0.5, {}),
        "challenge": (0.5, {}),
    }
    extra_splits = ("dev",)
    scenario_model = Track2Scenario
    outcome_model = Track2Outcome
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
    interval_columns = ("task_success", "task_model")
    #: Measured by ``tests/benchmarks/bench_track2_fidelity.py --inproc --per-family 4
    #: --first-seed 53000`` (imitation, waypoint, demo parser, task model: 30.7, 35.8).
    reference_spread = {"standard": 31.0, "challenge": 36.0}

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
    ) -> Scenario[Track2Scenario]:
        merged = {**self.splits.get(split, (1.0, {}))[1], **params}
        return self.new_scenario(seed=seed, split=split,
                                 hidden=make_track2_scenario(seed, split, merged, index))

    def make_episode(self, scenario: Scenario[Track2Scenario]) -> TrackEpisode:
        return Track2Episode(self.hidden(scenario))

    def write_inputs(self, scenario: Scenario[Track2Scenario], folder: Path) -> None:
        """The demonstration packet of the scenario's source, in ``folder/demo``."""
        from simhost.worlds.track2 import write_demo_packet

        s = self.hidden(scenario)
        write_demo_packet(folder / DEMO_FOLDER, s.source, seed=s.demo_seed, config=s.bench,
                          frames=s.demo_frames)

    def score(self, data: ScoringInput[Track2Scenario, Track2Outcome]) -> ScoreCard:
        from simhost.worlds.track2 import task_truth

        s = self.hidden(data.scenario)
        truth = task_truth(s.instance, s.bench)
        o = self.outcome_of(data)
        if o is None:  # the episode produced none: nothing happened
            o = Track2Outcome(family=s.family, max_attempts=s.max_attempts)
        model = _latest_model(data)
        parts = _scoring.model_parts(model, truth)
        invalid = data.invalid_actions + data.protocol_errors
        generalization = _scoring.generalization(o)
        task_model = sum(_scoring.MODEL_WEIGHTS[k] * v for k, v in parts.items())
        components = {
            "success": float(o.success),
            "adaptation": _scoring.adaptation(o, _scoring.granted_adapt_s(data.stage_budgets_s)),
            "generalization": generalization,
            "task_model": task_model,
            "stability": _scoring.stability(o, invalid),
        }
        total = sum(self.weights[k] * v for k, v in components.items())
        metrics = {
            "task_success": float(o.success),
            "task_model": task_model,
            "attempts": float(o.attempts_needed),
            "adapt_time_min": o.adapt_time_s / 60.0,
            "progress": generalization,
            "distance": s.distance,
            "invalid_actions": float(invalid),
            f"family_{s.family}": 1.0,
            **{f"task_model_{k}": v for k, v in parts.items()},
        }
        notes = [f"family={s.family}", f"attempts={len(o.attempts)}, success at "
                 f"{o.success_attempt or 'none'}"]
        if model is None:
            notes.append("no valid task_model.json")
        elif model.family != s.family:
            notes.append(f"task model names family {model.family!r}, the task is {s.family!r}")
        notes += [n for n in (ignored_note(name, parsed) for name, parsed in data.files.items())
                  if n is not None]
        return ScoreCard(track=self.name, total=min(1.0, max(0.0, total)),
                         components=components, weights=dict(self.weights), metrics=metrics,
                         notes=tuple(notes))

    def picture(self, episode_dir: Path, out: Path | None = None) -> Path:
        """The successful (else the last) attempt beside the demonstration."""
        return attempt_png(episode_dir, path=out)

    def preview(self, *, seed: int, split: str, out: Path) -> Path:
        """The demonstrated source beside the hidden instance of ``seed`` in ``split``."""
        scenario = self.make_scenario(seed=seed, split=split, params={"demo_frames": False})
        return preview_png(scenario, out)

    def step_pictures(self, episode: RecordedEpisode) -> list[StepPicture]:
        """Each attempt beside the demonstration, while the scrubber is in it."""
        return attempt_pictures(episode)

    def vocabulary(self) -> str:
        """The packet's arrays, the task-model names per family, how values compare."""
        return _vocabulary.vocabulary(self)

    def stratum(self, result: EpisodeResult) -> str:
        """The episode's family: a split's average is the mean of its families' means."""
        return next((fam for fam, _ in FAMILY_COLUMNS
                     if result.score.metrics.get(f"family_{fam}")), "")

    def summarize(self, results: Sequence[EpisodeResult]) -> dict[str, float | None]:
        """Table VII's row: per-family scores (0–100), their mean (``final``, Avg.), success
        and task-model percentages, mean attempts needed, adaptation and run time in
        minutes; per split, the mean over its families too."""
        row: dict[str, float | None] = {}
        for fam, _ in FAMILY_COLUMNS:
            row[fam] = mean([100.0 * r.score.total for r in results
                             if r.score.metrics.get(f"family_{fam}")])
        row["final"] = _family_mean(results)
        for split in sorted({r.split for r in results}):
            row[split] = _family_mean([r for r in results if r.split == split])

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


def _family_mean(results: Sequence[EpisodeResult]) -> float | None:
    """The mean over families of each family's mean score (0–100), as in Table VII."""
    per = [mean([100.0 * r.score.total for r in results
                 if r.score.metrics.get(f"family_{fam}")]) for fam, _ in FAMILY_COLUMNS]
    return mean([p for p in per if p is not None])
