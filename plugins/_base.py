"""The track plugin interface: the rules of the game, in one screen.

A track plugin is a class registered under the entry-point group ``eagc.tracks``::

    [project.entry-points."eagc.tracks"]
    sanity = "plugins.sanity:SanityTrack"

It defines the stages and their budgets, builds a hidden scenario from a seed, makes the live
episode (world + exception triggers) the sim host serves, verifies the agent's files and
scores the episode. Run ``plugins.conformance.TrackConformance`` against any new plugin.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from pydantic import BaseModel

from schemas import FileCheck, SchemaError, ScoreCard, parse_json, parse_jsonl
from schemas._result import EpisodeStatus
from simhost._episode import StageSpec, TrackEpisode


@dataclass(frozen=True)
class Scenario:
    """One hidden scenario. Organizer-only: never enters the agent's container."""

    track: str
    split: str
    seed: int
    params: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class FileRule:
    """A file the agent writes to /output: its model (``None``: JSON lines of log records)."""

    model: type[BaseModel] | None
    required: bool = True
    jsonl: bool = False


@dataclass(frozen=True)
class ScoringInput:
    """Everything the scorer may look at, as one object (fields can be added later)."""

    scenario: Scenario
    status: EpisodeStatus
    end_reason: str
    stages_reached: tuple[str, ...]
    outcome: Mapping[str, Any]
    files: Mapping[str, Any]
    snapshots: Mapping[str, Mapping[str, Any]]
    steps: int
    invalid_actions: int
    protocol_errors: int


class TrackPlugin(ABC):
    """A track: stages, scenarios, episodes, file checks and scoring."""

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

    @abstractmethod
    def stages(self) -> list[StageSpec]:
        """The stages, in order, with their official budgets."""

    @abstractmethod
    def make_scenario(self, *, seed: int, split: str, params: Mapping[str, Any]) -> Scenario:
        """The hidden scenario of ``seed`` in ``split``. Same arguments → same scenario."""

    @abstractmethod
    def make_episode(self, scenario: Scenario) -> TrackEpisode:
        """The live episode the sim host serves."""

    @abstractmethod
    def score(self, data: ScoringInput) -> ScoreCard:
        """Scores one episode, whatever way it ended."""

    def write_inputs(self, scenario: Scenario, folder: Path) -> None:  # noqa: B027
        """Writes read-only inputs mounted into the container (e.g. a demo packet)."""

    def verify_files(self, files: Mapping[str, bytes]) -> tuple[dict[str, Any], list[FileCheck]]:
        """Validates collected files against their schemas.

        Returns the parsed files that passed and one check per expected or present file.
        """
        parsed: dict[str, Any] = {}
        checks: list[FileCheck] = []
        for fname, rule in self.files.items():
            data = files.get(fname)
            if data is None:
                if rule.required:
                    checks.append(FileCheck(name=fname, ok=False, reason="missing"))
                continue
            try:
                if rule.jsonl:
                    parsed[fname] = parse_jsonl(data, source=fname)
                else:
                    assert rule.model is not None
                    parsed[fname] = parse_json(data, rule.model, source=fname)
                checks.append(FileCheck(name=fname, ok=True, size=len(data)))
            except SchemaError as e:
                checks.append(FileCheck(name=fname, ok=False, size=len(data), reason=str(e)))
        return parsed, checks

    def parse_snapshot(self, files: Mapping[str, bytes]) -> dict[str, Any]:
        """The files of one stage-end snapshot that parse (used by scorers)."""
        return self.verify_files(files)[0]
