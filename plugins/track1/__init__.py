"""Track 1 (entry point ``track1``): unseen-environment exploration and closed-loop execution.

Public API: ``Track1`` (the plugin), ``Track1Episode``, ``Track1Plan`` (the plan format),
``preview`` and ``trajectory_png`` (pictures for organizers). Light on import: MuJoCo loads
when an episode or a picture is made.
"""

from plugins.track1._episode import EXECUTION, EXPLORATION, PLANNING, Track1Episode
from plugins.track1._exceptions import Track1Plan
from plugins.track1._pictures import preview, trajectory_png
from plugins.track1._track import Track1

__all__ = ["EXECUTION", "EXPLORATION", "PLANNING", "Track1", "Track1Episode", "Track1Plan",
           "preview", "trajectory_png"]
