"""Track plugins: the rules of the game (stages, scenarios, exceptions, file checks, scores).

Public API: ``TrackPlugin``, ``Scenario``, ``ScoringInput``, ``FileRule``, ``load_track``,
``available_tracks``, ``PluginError``. The conformance suite is ``plugins.conformance``.
"""

from plugins._base import (
    Column,
    FileRule,
    Scenario,
    ScoringInput,
    TrackPlugin,
    granted_budgets,
    score_episode,
)
from plugins._errors import PluginError
from plugins._registry import GROUP, available_tracks, load_track, validate_plugin
from simhost._episode import Observation, StageSpec, StepOutcome, TrackEpisode

__all__ = [
    "GROUP",
    "Column",
    "FileRule",
    "Observation",
    "PluginError",
    "Scenario",
    "ScoringInput",
    "StageSpec",
    "StepOutcome",
    "TrackEpisode",
    "TrackPlugin",
    "available_tracks",
    "granted_budgets",
    "score_episode",
    "load_track",
    "validate_plugin",
]
