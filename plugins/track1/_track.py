"""``Track1``: unseen-environment exploration and closed-loop execution (paper §III).

Stages (Table II, official budgets; a campaign's ``time_scale`` and step caps scale them):
``exploration`` 20 min, ``planning`` 10 min (nothing moves; the plan ends it), ``execution``
60 min; besides, each episode has step budgets derived from its ground truth
(``_budgets``). Splits: ``standard`` (3–5 rooms, a robot's perception, two-clause
instructions, an exception in about half the episodes, weight 0.6) and ``challenge`` (6–8
rooms with more clutter, two or three clauses, always an exception, weight 0.4), as in
equation (2); ``dev`` is the public getting-started level (exact all-round perception,
one-clause templates, exceptions that show themselves). ``vision`` (an extra split, outside
the final) is ``standard`` without a detector: RGB-D, odometry, the range scan and the room
sign; no detections and no segmentation image; actions name what they act on by a pixel of
the last frame.
Files: ``world_model.json`` and ``episode_log.jsonl``, both required. Score: equation (1),
see ``_score``. Leaderboard: Table IV's columns; ties by task success, model verification,
recovery, invalid actions, runtime.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, ClassVar

from plugins._audit import EpisodeChecks
from plugins._base import Scenario, ScoringInput, TrackPlugin
from plugins._errors import PluginError
from plugins._files import EPISODE_LOG, FileRule, ParsedFile, check_files
from plugins._leaderboard import Column
from plugins._views import EpisodeMap, RecordedEpisode, TruthReport
from plugins.track1 import _score, _view, _vocabulary
from plugins.track1._episode import EXECUTION, EXPLORATION, PLANNING, Track1Episode
from plugins.track1._pictures import preview, trajectory_png
from plugins.track1._scenario import build_scenario
from plugins.track1._types import Track1Outcome, Track1Scenario
from plugins.track1.audit import Track1Checks
from schemas import EpisodeResult, FileCheck, ScoreCard, WorldModel
from simhost import StageSpec, TrackEpisode


class Track1(TrackPlugin[Track1Scenario, Track1Outcome]):
    name = "track1"
    title = "Track 1: unseen-environment exploration and closed-loop execution (houses)"
    weights = dict(_score.WEIGHTS)
    files = {
        "world_model.json": FileRule(WorldModel),
        EPISODE_LOG: FileRule(None, jsonl=True),
    }
    splits = {
        "standard": (0.6, {"exception_probability": 0.5, "goals": [2, 2]}),
        "challenge": (0.4, {"exception_probability": 1.0, "goals": [2, 3]}),
        "dev": (1.0, {"exception_probability": 0.5, "goals": [1, 1], "language": "templates",
                      "step_budgets": False}),
    }
    extra_splits = ("vision",)
    #: Scenario parameters of the extra splits: ``vision`` has the standard split's tasks,
    #: exceptions and budgets (its houses and sensing: ``simhost.worlds.track1.SPLITS``).
    extra_params: ClassVar[Mapping[str, Mapping[str, Any]]] = {
        "vision": splits["standard"][1],
    }
    scenario_model = Track1Scenario
    outcome_model = Track1Outcome
    columns = (
        Column("standard", "Std."),
        Column("challenge", "Ch."),
        Column("final", "Final"),
        Column("task_success", "Task Succ. %"),
        Column("model_verification", "Model Verif. %"),
        Column("recovery", "Recovery %"),
        Column("invalid_actions", "Invalid Act/Ep", lower_is_better=True),
        Column("latency_ms", "Latency ms", "{:.0f}", lower_is_better=True),
        Column("peak_mem_gb", "Peak Mem GB", "{:.2f}", lower_is_better=True),
        Column("runtime_min", "Runtime min", "{:.1f}", lower_is_better=True),
    )
    interval_columns = ("task_success", "model_verification", "recovery")
    #: Measured by ``tests/benchmarks/bench_track1_fidelity.py --standard 9100:9130
    #: --challenge 9100:9130`` (heuristic, memory-free, look-ahead, structured: 36.8, 27.2).
    reference_spread = {"standard": 37.0, "challenge": 27.0}
    tie_breaks = ("task_success", "model_verification", "recovery", "invalid_actions",
                  "runtime_min")

    def stages(self) -> list[StageSpec]:
        return [
            StageSpec(EXPLORATION, budget_s=20 * 60.0,
                      description="explore; build the topology, object states and a queryable "
                      "model (world_model.json)"),
            StageSpec(PLANNING, budget_s=10 * 60.0, allows_motion=False,
                      description="instruction and queries arrive; answer them, end the stage "
                      "with the plan (end_stage payload); nothing moves"),
            StageSpec(EXECUTION, budget_s=60 * 60.0,
                      description="execute, update the model, recover from the exception; "
                      "send done when finished"),
        ]

    def make_scenario(self, *, seed: int, split: str, params: Mapping[str, Any],
                      index: int | None = None) -> Scenario[Track1Scenario]:
        if split not in self.split_names():
            raise PluginError(f"track1: unknown split {split!r}; one of "
                              f"{sorted(self.split_names())}")
        own = self.splits[split][1] if split in self.splits else self.extra_params[split]
        merged = {**own, **params}
        return self.new_scenario(seed=seed, split=split,
                                 hidden=build_scenario(seed, split, merged, index))

    def make_episode(self, scenario: Scenario[Track1Scenario]) -> TrackEpisode:
        return Track1Episode(scenario, self.hidden(scenario))

    def verify_files(self, files: Mapping[str, bytes]
                     ) -> tuple[dict[str, ParsedFile], list[FileCheck]]:
        """The default check (``plugins._files.check_files``), and on a world model that
        passed, a line for each near-miss shape it holds (``_score.shape_notes``) and for
        each kind of id that is a name, not a number the host gave
        (``_score.named_id_notes``): the score card says the same."""
        parsed, checks = check_files(self.files, files)
        model = parsed.get("world_model.json")
        if not isinstance(model, WorldModel):
            return parsed, checks
        notes = _score.shape_notes(model) + [
            n.removeprefix("world model: ")
            for n in _score.named_id_notes(model, split_known=False)]
        return parsed, [c.model_copy(update={"reason": "\n".join(
                            x for x in (c.reason, *notes) if x)})
                        if c.name == "world_model.json" and c.ok and notes else c
                        for c in checks]

    def score(self, data: ScoringInput[Track1Scenario, Track1Outcome]) -> ScoreCard:
        return _score.score(data, self.name)

    def picture(self, episode_dir: Path, out: Path | None = None) -> Path:
        """The robot's trajectory over the house, coloured by stage."""
        path = trajectory_png(episode_dir)
        if out is not None and out != path:
            out.parent.mkdir(parents=True, exist_ok=True)
            path = path.replace(out)
        return path

    def preview(self, *, seed: int, split: str, out: Path) -> Path:
        """The top-down map with the task marked, beside the robot's first camera frame."""
        scenario = self.make_scenario(seed=seed, split=split, params={})
        return preview(self.hidden(scenario), seed, split, out)[0]

    def audit(self) -> EpisodeChecks:
        """Ids, rooms and hidden states a world model names before anything showed them;
        exceptions detected before anything could show them (``audit``)."""
        return Track1Checks()

    def episode_map(self, episode: RecordedEpisode) -> EpisodeMap | None:
        """The house from above (a team's view of a public seed: its plan, without the
        items; of a hidden seed nothing: the plan is what the team's world model is graded
        on, and the viewer draws the path alone)."""
        if not episode.organizer and not episode.public_seed:
            return None
        return _view.house_map(episode)

    def truth(self, episode: RecordedEpisode) -> TruthReport | None:
        """The world model graded at the end of exploration against the house."""
        return _view.model_against_truth(episode)

    def vocabulary(self) -> str:
        """Categories, affordances, failure reasons, reach, planning messages."""
        return _vocabulary.vocabulary(self)

    def summarize(self, results: Sequence[EpisodeResult]) -> dict[str, float | None]:
        """Table IV's row: Std., Ch., Final (eq. 2), Task Succ. %, Model Verif. %, Recovery %
        (over the episodes with an exception), Invalid Act/Ep, latency, memory, runtime."""
        row = super().summarize(results)
        for split in self.splits:
            row.setdefault(split, None)
        for key in ("task_success", "model_verification", "recovery"):
            row.setdefault(key, None)
        return row
