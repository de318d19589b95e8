"""Track 1 (entry point ``track1``): unseen-environment exploration and closed-loop execution.

Public API: ``Track1`` (the plugin), ``Track1Episode``, the typed vocabulary (``Task``,
``Goal``, ``Query``, ``Track1Scenario``, ``Track1Plan``, ``Track1Outcome``, …), and
``preview`` and ``trajectory_png`` (pictures for organizers). Light on import: MuJoCo loads
when an episode or a picture is made.
"""

from plugins.track1._episode import EXECUTION, EXPLORATION, PLANNING, Track1Episode
from plugins.track1._pictures import preview, trajectory_png
from plugins.track1._track import Track1
from plugins.track1._types import (
    EXCEPTION_TYPES,
    ExceptionRecord,
    ExceptionType,
    Goal,
    GoalProgress,
    GradedQuery,
    PlannedException,
    Query,
    Task,
    Track1Outcome,
    Track1Plan,
    Track1Scenario,
)

__all__ = [
    "EXCEPTION_TYPES",
    "EXECUTION",
    "EXPLORATION",
    "PLANNING",
    "ExceptionRecord",
    "ExceptionType",
    "Goal",
    "GoalProgress",
    "GradedQuery",
    "PlannedException",
    "Query",
    "Task",
    "Track1",
    "Track1Episode",
    "Track1Outcome",
    "Track1Plan",
    "Track1Scenario",
    "preview",
    "trajectory_png",
]
