"""Track plugins: the rules of the game (stages, scenarios, exceptions, file checks, scores).

Public API: ``TrackPlugin`` (generic over its scenario and outcome models; its hooks' types:
``EpisodeChecks``, ``AuditInput``, ``Finding``, ``RecordedEpisode``, ``EpisodeMap``,
``StepPicture``, ``TruthReport``), ``Scenario``, ``HiddenScenario``, ``ScoringInput``,
``EpisodeOutcome`` (the base of every track's outcome), ``FileRule``, ``load_track``,
``available_tracks``, ``registered_track``, ``PluginError``; what every track's audit
shares (``Finding``, ``Severity``, ``HostSteps``, ``log_step_findings``, ``STEP_SLACK``).
The conformance suite is ``plugins.conformance``.
"""

from plugins._audit import (
    STEP_SLACK,
    AuditInput,
    EpisodeChecks,
    Finding,
    HostSteps,
    Severity,
    Snapshot,
    log_step_findings,
)
from plugins._base import HiddenScenario, Scenario, ScoringInput, TrackPlugin, read_hidden
from plugins._errors import PluginError
from plugins._files import EPISODE_LOG, FileRule, ParsedFile
from plugins._leaderboard import Column
from plugins._registry import (
    GROUP,
    available_tracks,
    load_track,
    registered_track,
    validate_plugin,
)
from plugins._scoring import granted_budgets, score_episode
from plugins._views import EpisodeMap, RecordedEpisode, StepPicture, TruthReport
from simhost.host import EpisodeOutcome, Observation, StageSpec, StepOutcome, TrackEpisode

__all__ = [
    "EPISODE_LOG",
    "GROUP",
    "STEP_SLACK",
    "AuditInput",
    "Column",
    "EpisodeChecks",
    "EpisodeMap",
    "EpisodeOutcome",
    "FileRule",
    "Finding",
    "HiddenScenario",
    "HostSteps",
    "Observation",
    "ParsedFile",
    "PluginError",
    "RecordedEpisode",
    "Scenario",
    "ScoringInput",
    "Severity",
    "Snapshot",
    "StageSpec",
    "StepOutcome",
    "StepPicture",
    "TrackEpisode",
    "TrackPlugin",
    "TruthReport",
    "available_tracks",
    "granted_budgets",
    "load_track",
    "log_step_findings",
    "read_hidden",
    "registered_track",
    "score_episode",
    "validate_plugin",
]
