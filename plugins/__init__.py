"""Track plugins: the rules of the game (stages, scenarios, exceptions, file checks, scores).

Public API: ``TrackPlugin`` (generic over its scenario and outcome models), ``Scenario``,
``ScoringInput``, ``EpisodeOutcome`` (the base of every track's outcome), ``FileRule``,
``load_track``, ``available_tracks``, ``PluginError``; what every track's audit shares
(``Finding``, ``Severity``, ``HostSteps``, ``log_step_findings``, ``STEP_SLACK``). The
conformance suite is ``plugins.conformance``.
"""

from plugins._audit import STEP_SLACK, Finding, HostSteps, Severity, log_step_findings
from plugins._base import (
    EPISODE_LOG,
    Column,
    FileRule,
    ParsedFile,
    Scenario,
    ScoringInput,
    TrackPlugin,
    granted_budgets,
    score_episode,
)
from plugins._errors import PluginError
from plugins._registry import GROUP, available_tracks, load_track, validate_plugin
from simhost.host._episode import EpisodeOutcome, Observation, StageSpec, StepOutcome, TrackEpisode

__all__ = [
    "EPISODE_LOG",
    "GROUP",
    "STEP_SLACK",
    "Column",
    "EpisodeOutcome",
    "FileRule",
    "Finding",
    "HostSteps",
    "Observation",
    "ParsedFile",
    "PluginError",
    "Scenario",
    "ScoringInput",
    "Severity",
    "StageSpec",
    "StepOutcome",
    "TrackEpisode",
    "TrackPlugin",
    "available_tracks",
    "granted_budgets",
    "score_episode",
    "load_track",
    "log_step_findings",
    "validate_plugin",
]
