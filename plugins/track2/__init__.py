"""Track 2 (entry point ``track2``): one-demonstration rapid adaptation on the bench.

Public API: ``Track2`` (the plugin), ``Track2Episode`` (the live episode),
``Track2Scenario`` (the hidden scenario, typed), ``Track2SplitParams`` (a split's
parameters), ``Track2Outcome`` / ``AttemptRecord``
(what an episode achieved), ``attempt_png`` (an attempt drawn beside the demonstration, from
an episode folder), and the scoring helpers ``model_score`` / ``model_parts`` (a task
model against ``simhost.worlds.track2.task_truth``).
"""

from plugins.track2._episode import Track2Episode
from plugins.track2._outcome import AttemptRecord, Track2Outcome
from plugins.track2._picture import attempt_png
from plugins.track2._scenario import Track2Scenario, Track2SplitParams
from plugins.track2._scoring import WEIGHTS, model_parts, model_score
from plugins.track2._track import Track2

__all__ = ["WEIGHTS", "AttemptRecord", "Track2", "Track2Episode", "Track2Outcome",
           "Track2Scenario", "Track2SplitParams", "attempt_png", "model_parts", "model_score"]
