"""The track plugin interface: the rules of the game, in one screen.

A track plugin is a class registered under the entry-point group ``eagc.tracks``::

    [project.entry-points."eagc.tracks"]
    sanity = "plugins.sanity:SanityTrack"

It is the only way a track's behaviour enters eagc. It defines the stages and their
budgets, builds a hidden scenario from a seed, makes the live episode (world + exception
triggers) the sim host serves, verifies the agent's files and scores the episode; hooks
with defaults add its leaderboard row, pictures, audit checks, what the viewer shows of an
episode and its words on the protocol page. Run ``plugins.conformance.TrackConformance``
(and, with an agent, ``orchestrator.conformance.TrackEpisodeConformance``) against any new
plugin.

A plugin is generic over its two models, ``TrackPlugin[ScenarioT, OutcomeT]``: the hidden
scenario (``scenario_model``, a pydantic model whose JSON is ``Scenario.params``) and what
an episode achieved (``outcome_model``, an ``EpisodeOutcome``). Both travel typed from
``make_scenario`` to ``make_episode`` and from ``TrackEpisode.outcome`` to ``score``. Where
the scenario came from outside (a replay, the episode's log), the scenario model reads it
back: ``HiddenScenario.of`` (``read_hidden`` for any model).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, Generic, Self, TypeVar

from pydantic import BaseModel

from plugins._audit import EpisodeChecks
from plugins._errors import PluginError
from plugins._files import EPISODE_LOG, FileRule, ParsedFile, check_files
from plugins._leaderboard import DEFAULT_COLUMNS, Column, mean_row
from plugins._views import EpisodeMap, RecordedEpisode, StepPicture, TruthReport
from schemas import EndReason, EpisodeResult, EpisodeStatus, FileCheck, LogRecord, ScoreCard
from simhost.host import EpisodeOutcome, ScenarioRecord, StageSpec, TrackEpisode

#: A track's hidden-scenario model.
ScenarioT = TypeVar("ScenarioT", bound=BaseModel)
#: A track's episode-outcome model.
OutcomeT = TypeVar("OutcomeT", bound=EpisodeOutcome)
FileT = TypeVar("FileT", bound=BaseModel)
ModelT = TypeVar("ModelT", bound=BaseModel)


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
    #: JSON (``HiddenScenario.of`` then reads ``params``).
    hidden: ScenarioT | None = field(default=None, compare=False, repr=False)


#: Where a hidden scenario is read back from: a ``Scenario``, the episode log's
#: ``ScenarioRecord``, or the params themselves.
ScenarioSource = Scenario[Any] | ScenarioRecord | Mapping[str, Any]


def read_hidden(model: type[ModelT], source: ScenarioSource) -> ModelT:
    """The typed hidden scenario of ``source``: its ``hidden`` when that is a ``model``,
    else its params read back with ``model`` (pydantic's ``ValidationError`` when they do
    not fit)."""
    if isinstance(source, Mapping):
        return model.model_validate(dict(source))
    got = getattr(source, "hidden", None)
    return got if isinstance(got, model) else model.model_validate(source.params)


class HiddenScenario(BaseModel):
    """A base for a track's hidden-scenario model: the model reads itself back (``of``)."""

    @classmethod
    def of(cls, source: ScenarioSource) -> Self:
        """The typed hidden scenario of a ``Scenario``, a ``ScenarioRecord`` or params."""
        return read_hidden(cls, source)


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


class TrackPlugin(ABC, Generic[ScenarioT, OutcomeT]):
    """A track: stages, scenarios, episodes, file checks, scoring, and hooks with defaults."""

    # ------------------------------------------------------------------ the interface
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
    #: The hidden-scenario model (``Scenario.params`` is its JSON).
    scenario_model: type[ScenarioT]
    #: What an episode achieved (``TrackEpisode.outcome`` returns one).
    outcome_model: type[OutcomeT]

    @abstractmethod
    def stages(self) -> list[StageSpec]:
        """The stages, in order, with their official budgets."""

    @abstractmethod
    def make_scenario(
        self, *, seed: int, split: str, params: Mapping[str, Any], index: int | None = None
    ) -> Scenario[ScenarioT]:
        """The hidden scenario of ``seed`` in ``split`` (built with ``new_scenario``); same
        arguments → same scenario. ``index``: the episode's index within its split in a
        campaign (e.g. to balance task families by ``index mod n``), None for a one-off."""

    @abstractmethod
    def make_episode(self, scenario: Scenario[ScenarioT]) -> TrackEpisode:
        """The live episode the sim host serves."""

    @abstractmethod
    def score(self, data: ScoringInput[ScenarioT, OutcomeT]) -> ScoreCard:
        """Scores one episode, whatever way it ended."""

    # ------------------------------------------------------- the leaderboard (defaults)
    #: Leaderboard columns after the team (override with the track's table layout).
    columns: ClassVar[tuple[Column, ...]] = DEFAULT_COLUMNS
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
    #: Public splits a scenario can also be made for (e.g. ``dev``), outside the final score.
    extra_splits: ClassVar[tuple[str, ...]] = ()

    def summarize(self, results: Sequence[EpisodeResult]) -> dict[str, float | None]:
        """One submission's leaderboard row from its scored episodes, on a 0–100 scale
        (default ``plugins._leaderboard.mean_row``: eq. 2 over the splits, the metrics'
        means, resources). Tracks override it for their table's columns."""
        return mean_row(results, self.splits)

    def stratum(self, result: EpisodeResult) -> str:
        """The part of its split an episode's score is averaged in before the split's mean
        (``summarize``): "" when a split's score is the plain mean of its episodes. The
        leaderboard resamples within these strata for its intervals."""
        return ""

    # ------------------------------------------------------------- hooks (defaults)
    def write_inputs(self, scenario: Scenario[ScenarioT], folder: Path) -> None:  # noqa: B027
        """Writes read-only inputs mounted into the container (e.g. a demo packet)."""

    def verify_files(self, files: Mapping[str, bytes]
                     ) -> tuple[dict[str, ParsedFile], list[FileCheck]]:
        """The collected files that parse, and one check per expected or present file
        (``plugins._files.check_files``; ``eagc check-files`` runs this too)."""
        return check_files(self.files, files)

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

    def audit(self) -> EpisodeChecks | None:
        """A fresh set of this track's own checks for one episode's audit (``eagc audit``;
        ``plugins._audit``). None: the replay and the log steps only."""
        return None

    def episode_map(self, episode: RecordedEpisode) -> EpisodeMap | None:
        """The picture the viewer draws the episode's path over (``plugins._views``).
        None: the path alone."""
        return None

    def step_pictures(self, episode: RecordedEpisode) -> list[StepPicture]:
        """Pictures of spans of the episode's steps, shown as the viewer's scrubber passes
        them (Track 2: each attempt beside the demonstration). Default: none."""
        return []

    def truth(self, episode: RecordedEpisode) -> TruthReport | None:
        """Organizers only: the agent's model against the hidden truth. None: nothing to
        compare."""
        return None

    def vocabulary(self) -> str:
        """Markdown that ends the track's section of the protocol page: the words its
        observations, files and scores use (``plugins.protocol_doc``). "": none."""
        return ""

    # -------------------------------------------------------------------- helpers
    def split_names(self) -> tuple[str, ...]:
        """Every split ``make_scenario`` accepts: ``splits`` then ``extra_splits``."""
        return (*self.splits, *(s for s in self.extra_splits if s not in self.splits))

    def new_scenario(self, *, seed: int, split: str, hidden: ScenarioT) -> Scenario[ScenarioT]:
        """A scenario of this track around ``hidden``: its JSON as ``params``, and typed as
        that JSON reads back, so that the episode runs on what its log records."""
        params = hidden.model_dump(mode="json")
        return Scenario(track=self.name, split=split, seed=seed, params=params,
                        hidden=self.scenario_model.model_validate(params))

    def hidden(self, scenario: ScenarioSource) -> ScenarioT:
        """The typed hidden scenario (``read_hidden`` with ``scenario_model``)."""
        return read_hidden(self.scenario_model, scenario)

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

    def parse_snapshot(self, files: Mapping[str, bytes]) -> dict[str, ParsedFile]:
        """The files of one stage-end snapshot that parse (used by scorers)."""
        return self.verify_files(files)[0]
