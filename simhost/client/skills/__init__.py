"""Public Track 1 skills: an occupancy map and a world model the agent keeps from its own
observations, and blocking skills on top of them (``docs/skills.md``).

Importable in a team's container: pydantic, eclipse-zenoh and numpy only, like
``simhost.client``. Nothing here reads hidden state: only the ``TimeStep`` replies (the
observation's odometry, range scan, room sign, hand, collision flag and detections) and the
host's messages.

- ``Skills(env, ts)``: ``go_to(thing)`` / ``go_to(room=…)``, ``explore_next()``,
  ``fetch(id)``, ``place(id, receptacle)``, ``drop()``, ``open(id)``, ``use(tool,
  target)``; each steps the episode until it is done or failed and returns an ``Outcome``
  (status, the host's failure reason as it gave it or the skill's own, steps used, the
  doors found locked and containers found unavailable on the way).
- ``Explorer``: the map (``Grid``), the model (``WorldModel``, ``Thing``) and one-step
  motion (``Navigator``, ``DoorOpener``; ``act_on``, ``next_goal``, ``pursue``), which the
  Track 1 baselines (``examples/track1_common``) extend.
- ``parse(text)``, ``thing(phrase)``: the instruction and a description ("the red mug on the
  shelf") read into goals and references; ``WorldModel.matches(ref)`` finds what fits.
"""

from simhost.client.skills._explorer import Explorer
from simhost.client.skills._language import parse, thing
from simhost.client.skills._mapping import Grid, steer
from simhost.client.skills._model import (
    AFFORDANCES,
    READS_RIGHT_WITHIN,
    SIZES,
    Thing,
    WorldModel,
)
from simhost.client.skills._navigation import (
    DoorOpener,
    Navigator,
    door_normal,
    escape_move,
    face,
    facing,
    near,
    reach_radius,
)
from simhost.client.skills._skills import (
    ABSENCE_RANGE,
    DETECT_WINDOW,
    EXPLORED,
    FETCH_PATIENCE,
    GAVE_UP,
    NOT_HOLDING,
    NOT_IN_MODEL,
    RETRY_REASONS,
    STAGE_ENDING,
    STAGE_OVER,
    UNREACHABLE,
    UNREACHABLE_OPENS,
    Outcome,
    Skills,
)

__all__ = [
    "ABSENCE_RANGE",
    "AFFORDANCES",
    "DETECT_WINDOW",
    "EXPLORED",
    "FETCH_PATIENCE",
    "GAVE_UP",
    "NOT_HOLDING",
    "NOT_IN_MODEL",
    "READS_RIGHT_WITHIN",
    "RETRY_REASONS",
    "SIZES",
    "STAGE_ENDING",
    "STAGE_OVER",
    "UNREACHABLE",
    "UNREACHABLE_OPENS",
    "DoorOpener",
    "Explorer",
    "Grid",
    "Navigator",
    "Outcome",
    "Skills",
    "Thing",
    "WorldModel",
    "door_normal",
    "escape_move",
    "face",
    "facing",
    "near",
    "parse",
    "reach_radius",
    "steer",
    "thing",
]
