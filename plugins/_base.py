"""The track plugin interface: the rules of the game, in one screen.

A track plugin is a class registered under the entry-point group ``eagc.tracks``::

    [project.entry-points."eagc.tracks"]
    sanity = "plugins.sanity:SanityTrack"

It defines the stages and their budgets, builds a hidden scenario from a seed, makes the live
episode (world + exception triggers) the sim host serves, verifies the agent's files and
scores the episode. Run ``plugins.conformance.TrackConformance`` against any new plugin.

A plugin is generic over its two models, ``TrackPlugin[ScenarioT, OutcomeT]``: the hidden
scenario (``scenario_model``, a pydantic model whose JSON is ``Scenario.params``) and what
an episode achieved (``outcome_model``, an ``EpisodeOutcome``). Both travel typed from
``make_scenario`` to ``make_episode`` and from ``TrackEpisode.outcome`` to ``score``; their
JSON is read back (``hidden``, ``outcome_of``) only where it came from outside, e.g. a replay
rebuilding the scenario from the episode's log.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, Generic, TypeVar

from pydantic import BaseModel

from plugins._errors import PluginError
from schemas import (
    EndReason,
    EpisodeResult,
    FileCheck,
    LogRecord,
    SchemaError,
    ScoreCard,
    parse_episode_log,
    parse_json,
)
from schemas._io import ignored_note
from schemas._result import EpisodeStatus
from simhost.host._episode import EpisodeOutcome, StageSpec, TrackEpisode
from simhost.host._records import ScenarioRecord

#: A track's hidden-scenario model.
ScenarioT = TypeVar("ScenarioT", bound=BaseModel)
#: A track's episode-outcome model.
OutcomeT = TypeVar("OutcomeT", bound=EpisodeOutcome)
FileT = TypeVar("FileT", bound=BaseModel)

#: A collected file as ``verify_files`` parsed it: its ``FileRule.model``, or the records of
#: a JSON-lines log.
ParsedFile = BaseModel | list[LogRecord]
#: The episode log every track collects (``FileRule(None, jsonl=True)``).
EPISODE_LOG = "episode_log.jsonl"


@dataclass(frozen=True)
class Scenario(Generic[ScenarioT]):
    """One hidden scenario. Organizer-only: never enters the agent's container."""

    track: str
    split: str
    seed: int
    #: The hidden scenario as JSON: what the episode's log records and a replay rebuilds
    #: the scenario from.
    params: Mapping[str, Any] = field(default_factory=dict)
    #: The same, typed (``TrackPlugin.new_scenario``); None in a scenario rebuilt from its
    #: JSON (``TrackPlugin.hidden`` then reads ``params``).
    hidden: ScenarioT | None = field(default=None, compare=False, repr=False)


@dataclass(frozen=True)
class FileRule:
    """A file the agent writes to /output: its model (``None``: JSON lines of log records,
    checked by ``schemas.parse_episode_log``)."""

    model: type[BaseModel] | None
    required: bool = True
    jsonl: bool = False


@dataclass(frozen=True)
class ScoringInput(Generic[ScenarioT, OutcomeT]):
    """Everything the scorer may look at, as one object (fields can be added later)."""

    scenario: Scenario[ScenarioT]
    status: EpisodeStatus
    end_reason: EndReason
    stages_reached: tuple[str, ...]
    #: What the episode achieved (``TrackEpisode.outcome``); None when it produced nothing.
    outcome: OutcomeT | None
    #: The final files that passed ``verify_files``, by name.
    files: Mapping[str, ParsedFile]
    #: Stage name -> the files of that stage's end snapshot that passed.
    snapshots: Mapping[str, Mapping[str, ParsedFile]]
    steps: int
    invalid_actions: int
    protocol_errors: int
    #: Wall-clock budget each stage was granted (s, after the campaign's time scale):
    #: ``granted_budgets(plugin.stages(), time_scale)``.
    stage_budgets_s: Mapping[str, float]

    def file(self, name: str, model: type[FileT]) -> FileT | None:
        """The final file ``name`` if it parsed as ``model``, else None."""
        got = self.files.get(name)
        return got if isinstance(got, model) else None

    def snapshot(self, stage: str, name: str, model: type[FileT]) -> FileT | None:
        """File ``name`` of ``stage``'s end snapshot if it parsed as ``model``, else None."""
        got = self.snapshots.get(stage, {}).get(name)
        return got if isinstance(got, model) else None

    def log(self) -> list[LogRecord]:
        """The records of the final episode log (``[]`` when it is missing or refused)."""
        got = self.files.get(EPISODE_LOG)
        return list(got) if isinstance(got, list) else []


def granted_budgets(stages: Sequence[StageSpec], time_scale: float = 1.0) -> dict[str, float]:
    """Each stage's wall-clock budget as the sim host grants it (official × ``time_scale``)."""
    return {s.name: s.budget_s * time_scale for s in stages}


@dataclass(frozen=True)
class Column:
    """A leaderboard column: ``key`` in the row ``summarize`` returns."""

    key: str
    title: str
    fmt: str = "{:.1f}"
    lower_is_better: bool = False


def _mean(values: Sequence[float]) -> float | None:
    return sum(values) / len(values) if values else None


def resource_columns(results: Sequence[EpisodeResult]) -> dict[str, float | None]:
    """The columns every track shares: agent latency (median of the episodes' medians),
    peak memory (the largest), mean runtime, and the number of episodes."""
    lat = [r.stats.latency_ms_median for r in results if r.stats.latency_ms_median is not None]
    mem = [r.stats.peak_memory_bytes for r in results if r.stats.peak_memory_bytes]
    return {
        "latency_ms": sorted(lat)[len(lat) // 2] if lat else None,
        "peak_mem_gb": max(mem) / 2**30 if mem else None,
        "runtime_min": _mean([r.stats.wall_s / 60 for r in results]),
        "episodes": float(len(results)),
    }


class TrackPlugin(ABC, Generic[ScenarioT, OutcomeT]):
    """A track: stages, scenarios, episodes, file checks, scoring and its leaderboard."""

    #: The hidden-scenario model (``Scenario.params`` is its JSON).
    scenario_model: type[ScenarioT]
    #: What an episode achieved (``TrackEpisode.outcome`` returns one).
    outcome_model: type[OutcomeT]

    #: Leaderboard columns after the team (override with the track's table layout).
    columns: ClassVar[tuple[Column, ...]] = (
        Column("final", "Final"),
        Column("task_success", "Task Succ. %"),
        Column("invalid_actions", "Invalid Act/Ep", lower_is_better=True),
        Column("latency_ms", "Latency ms", "{:.0f}", lower_is_better=True),
        Column("peak_mem_gb", "Peak Mem GB", "{:.2f}", lower_is_better=True),
        Column("runtime_min", "Runtime min", "{:.1f}", lower_is_better=True),
    )
    #: Row keys that break ties after ``final``, in order (paper: task success first).
    tie_breaks: ClassVar[tuple[str, ...]] = ("task_success", "invalid_actions", "runtime_min")
    #: Row keys that are the mean of a per-episode score metric (x 100) and get a 95 %
    #: interval on the leaderboard beside the final's.
    interval_columns: ClassVar[tuple[str, ...]] = ("task_success",)
    #: Split -> standard deviation (points) of the per-episode score difference of two
    #: teams on the same episode, measured between neighbouring baselines by the track's
    #: calibration benchmark: what ``eagc campaign plan`` sizes a campaign by without a
    #: pilot. Empty: no reference (a pilot is needed).
    reference_spread: ClassVar[Mapping[str, float]] = {}

    #: Name used in campaigns and on the command line (the entry-point name).
    name: ClassVar[str]
    #: One line for listings.
    title: ClassVar[str]
    #: Score component → weight; weights sum to 1.
    weights: ClassVar[Mapping[str, float]]
    #: Files collected from /output, by name.
    files: ClassVar[Mapping[str, FileRule]]
    #: Split name → (weight in the final score, scenario parameters).
    splits: ClassVar[Mapping[str, tuple[float, Mapping[str, Any]]]]
    #: Public splits a scenario can also be made for (e.g. ``dev``), outside the final score.
    extra_splits: ClassVar[tuple[str, ...]] = ()

    def split_names(self) -> tuple[str, ...]:
        """Every split ``make_scenario`` accepts: ``splits`` then ``extra_splits``."""
        return (*self.splits, *(s for s in self.extra_splits if s not in self.splits))

    @abstractmethod
    def stages(self) -> list[StageSpec]:
        """The stages, in order, with their official budgets."""

    @abstractmethod
    def make_scenario(
        self, *, seed: int, split: str, params: Mapping[str, Any], index: int | None = None
    ) -> Scenario[ScenarioT]:
        """The hidden scenario of ``seed`` in ``split`` (``new_scenario``). Same arguments →
        same scenario.

        ``index`` is the episode's index within its split in a campaign (e.g. to balance
        task families by ``index mod n``), ``None`` for a one-off episode.
        """

    @abstractmethod
    def make_episode(self, scenario: Scenario[ScenarioT]) -> TrackEpisode:
        """The live episode the sim host serves."""

    @abstractmethod
    def score(self, data: ScoringInput[ScenarioT, OutcomeT]) -> ScoreCard:
        """Scores one episode, whatever way it ended."""

    def new_scenario(self, *, seed: int, split: str, hidden: ScenarioT) -> Scenario[ScenarioT]:
        """A scenario of this track around ``hidden``: its JSON as ``params``, and typed as
        that JSON reads back, so that the episode runs on what its log records."""
        params = hidden.model_dump(mode="json")
        return Scenario(track=self.name, split=split, seed=seed, params=params,
                        hidden=self.scenario_model.model_validate(params))

    def hidden(self, scenario: Scenario[Any] | ScenarioRecord) -> ScenarioT:
        """The typed hidden scenario: ``scenario.hidden``, else its ``params`` read back (a
        scenario rebuilt from an episode's log, or the log's own ``ScenarioRecord``)."""
        got = getattr(scenario, "hidden", None)
        if isinstance(got, self.scenario_model):
            return got
        return self.scenario_model.model_validate(scenario.params)

    def outcome_of(self, data: ScoringInput[ScenarioT, Any]) -> OutcomeT | None:
        """The episode's typed outcome; None when it produced none. An outcome given as its
        JSON (a stored or hand-written one) is read back with ``outcome_model``."""
        got = data.outcome
        if got is None or isinstance(got, self.outcome_model):
            return got
        if isinstance(got, Mapping):
            return self.outcome_model.model_validate(dict(got)) if got else None
        raise PluginError(f"track {self.name!r}: the outcome is a {type(got).__name__}, "
                          f"not a {self.outcome_model.__name__}")

    def picture(self, episode_dir: Path, out: Path | None = None) -> Path:
        """Draws a recorded episode as a PNG (title: track, seed, split, outcome; a legend
        for every colour and marker; a scale) and returns its path (default: in the
        episode's ``host/`` folder). Raises ``PluginError`` when the track has none,
        ``ValueError`` when the folder is not one of this track's episodes."""
        raise PluginError(f"track {self.name!r} draws no pictures of episodes")

    def preview(self, *, seed: int, split: str, out: Path) -> Path:
        """Draws the scenario of a (public) seed as a PNG in folder ``out`` and returns its
        path. Raises ``PluginError`` when the track has no previews."""
        raise PluginError(f"track {self.name!r} has no scenario previews")

    def write_inputs(self, scenario: Scenario, folder: Path) -> None:  # noqa: B027
        """Writes read-only inputs mounted into the container (e.g. a demo packet)."""

    def verify_files(self, files: Mapping[str, bytes]
                     ) -> tuple[dict[str, ParsedFile], list[FileCheck]]:
        """Validates collected files against their schemas (``eagc check-files`` runs
        this too, so that a team sees what the host sees).

        Returns the parsed files that passed and one check per expected or present file:
        a refused file's ``reason`` holds every problem, one line per field path
        (``schemas._io.problem_lines``); a passed file's, the keys nothing grades (they
        are ignored, never a reason to refuse the file).
        """
        parsed: dict[str, ParsedFile] = {}
        checks: list[FileCheck] = []
        for fname, rule in self.files.items():
            data = files.get(fname)
            if data is None:
                if rule.required:
                    checks.append(FileCheck(name=fname, ok=False, reason="missing"))
                continue
            try:
                if rule.jsonl:
                    parsed[fname] = parse_episode_log(data, source=fname)
                else:
                    assert rule.model is not None
                    parsed[fname] = parse_json(data, rule.model, source=fname)
                note = ignored_note(fname, parsed[fname])
                checks.append(FileCheck(name=fname, ok=True, size=len(data),
                                        reason="" if note is None
                                        else note.removeprefix(f"{fname}: ")))
            except SchemaError as e:
                checks.append(FileCheck(name=fname, ok=False, size=len(data), reason=e.detail))
        return parsed, checks

    def summarize(self, results: Sequence[EpisodeResult]) -> dict[str, float | None]:
        """One submission's leaderboard row from its scored episodes, on a 0–100 scale.

        Default: the mean total per split, ``final`` as the split-weighted mean (paper
        eq. 2; the plain mean when one split), score metrics averaged (``task_success``
        etc. as percentages), invalid actions per episode, median agent latency, peak
        memory and runtime. Tracks override it for their table's columns.
        """
        by_split: dict[str, list[float]] = {}
        for r in results:
            by_split.setdefault(r.split, []).append(100.0 * r.score.total)
        row: dict[str, float | None] = {s: _mean(v) for s, v in by_split.items()}
        weights = {s: self.splits.get(s, (1.0, {}))[0] for s in by_split}
        if len(by_split) == 1:
            row["final"] = _mean([100.0 * r.score.total for r in results])
        else:
            total_w = sum(weights.values())
            row["final"] = sum(weights[s] * (row[s] or 0.0) for s in by_split) / total_w
        keys = {k for r in results for k in r.score.metrics}
        for k in sorted(keys):
            vals = [r.score.metrics[k] for r in results if k in r.score.metrics]
            scale = 1.0 if k == "invalid_actions" else 100.0
            row[k] = None if not vals else scale * sum(vals) / len(vals)
        row["invalid_actions"] = _mean(
            [r.stats.invalid_actions + sum(
                n for c, n in r.stats.protocol_errors.items() if c != "invalid_action")
             for r in results])
        row.update(resource_columns(results))
        return row

    def stratum(self, result: EpisodeResult) -> str:
        """The part of its split an episode's score is averaged in before the split's mean
        (``summarize``): "" when a split's score is the plain mean of its episodes. The
        leaderboard resamples within these strata for its intervals."""
        return ""

    def parse_snapshot(self, files: Mapping[str, bytes]) -> dict[str, ParsedFile]:
        """The files of one stage-end snapshot that parse (used by scorers)."""
        return self.verify_files(files)[0]


def score_episode(plugin: TrackPlugin[ScenarioT, OutcomeT], scenario: Scenario[ScenarioT] | None,
                  *, status: EpisodeStatus, end_reason: EndReason,
                  stages_reached: Sequence[str], outcome: OutcomeT | None,
                  files: Mapping[str, ParsedFile],
                  snapshots: Mapping[str, Mapping[str, ParsedFile]], steps: int,
                  invalid_actions: int, protocol_errors: int,
                  time_scale: float = 1.0) -> ScoreCard:
    """The one way an episode is scored: the worker and every benchmark harness call it.

    An episode that never started (no scenario, the agent never started, an
    infrastructure failure) gets a zero card saying why. Otherwise the plugin scores it
    against the budgets the episode was granted (official x ``time_scale``), and the card
    notes an agent failure, or a last stage that used up its step budget."""
    if scenario is None or status in (EpisodeStatus.AGENT_NO_START, EpisodeStatus.INFRA_ERROR):
        return ScoreCard(track=plugin.name, total=0.0,
                         components=dict.fromkeys(plugin.weights, 0.0),
                         weights=dict(plugin.weights), notes=(f"not scored: {status.value}",))
    card = plugin.score(ScoringInput(
        scenario=scenario, status=status, end_reason=end_reason,
        stages_reached=tuple(stages_reached), outcome=outcome, files=files,
        snapshots=snapshots, steps=steps, invalid_actions=invalid_actions,
        protocol_errors=protocol_errors,
        stage_budgets_s=granted_budgets(plugin.stages(), time_scale)))
    if status.failure_kind == "agent":
        note = f"agent failure: {status}"
    elif end_reason == EndReason.STEPS:
        last = stages_reached[-1] if stages_reached else "?"
        note = f"the last stage {last!r} used its step budget: the task is scored as far as it got"
    else:
        return card
    return card.model_copy(update={"notes": (*card.notes, note)})
