"""Track 2 (entry point ``track2``): one-demonstration rapid adaptation on the bench.

Public API: ``Track2`` (the plugin), ``Track2Episode`` (the live episode), ``attempt_png``
(an attempt drawn beside the demonstration, from an episode folder), and the scoring
helpers ``model_score`` / ``model_parts`` (a task model against ``task_truth``).
"""

from plugins.track2._episode import Track2Episode
from plugins.track2._picture import attempt_png
from plugins.track2._scoring import WEIGHTS, model_parts, model_score
from plugins.track2._track import Track2

__all__ = ["WEIGHTS", "Track2", "Track2Episode", "attempt_png", "model_parts", "model_score"]
