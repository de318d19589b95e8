"""Trajectory baseline for Track 2 (OSVI-WM style): a learned world model of the bench and
the demonstration's trajectory adapted by planning through it.

Uses only ``simhost.client``, ``schemas``, numpy and the standard library; it builds on the
demo-parser image (its packet reader, demonstration parser, perception and primitives).

- ``parsing``: the demonstration as phases (``parse.py``), each a goal configuration of
  the parts relative to a reference row and a path (the hand's in the held part's frame,
  a tool tip's relative to what it acts on); ``task_model.json`` says what a trajectory
  model knows: the family, the state it tracks (the hand, the parts' poses) and the goal
  pose where the public vocabulary names it (a turn and its direction, a depth, the parts
  stacked, the opening's sense and fraction, the tool's slot, the target's travel or
  offset), as constraints and as the goal variables' target values. No stages,
  preconditions or conditions beyond the goal pose (a part let go): task structure.
- ``execution``: each phase planned through the learned part dynamics (``mpc.py``,
  ``worldmodel.py``, the weights in ``dynamics.npz``), replanned from the parts as they are
  while a part is off its goal; each attempt starts over.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

# In the image the demo parser's modules sit beside this file (/app); in a checkout they
# are in the sibling folder.
_HERE = Path(__file__).resolve().parent
if not (_HERE / "demoparser.py").is_file():
    sys.path.insert(1, str(_HERE.parent / "track2_demoparser"))

import numpy as np  # noqa: E402
from demoparser import GOAL_EVENTS, STATE_EVENTS, demo_hints, main, segment  # noqa: E402
from demoparser import Agent as DemoParser  # noqa: E402
from mpc import Memory, execute  # noqa: E402
from parse import compose  # noqa: E402
from taskmodel import task_model  # noqa: E402
from worldmodel import PartDynamics, kind_of  # noqa: E402

from schemas import TaskModel  # noqa: E402

# The goal pose in the public vocabulary, per family: what a trajectory shows. Constraints
# that state it, and the goal variables whose target value is it (the success criteria on
# anything else, such as a part let go, are task structure: left out).
GOAL_CONSTRAINTS = {"insertion": ("hole_depth",), "rotation": ("turn_angle", "turn_direction"),
                    "assembly": ("n_parts",), "opening": ("direction",),
                    "tool_use": ("tool_slot",)}
GOAL_VARIABLES = ("insertion_depth", "knob_turn", "_placed", "_opening", "button_travel",
                  "puck_goal_offset")


class Agent(DemoParser):
    name = "eagc-track2-trajectory/1"

    def __init__(self) -> None:
        super().__init__()
        self.dynamics = PartDynamics.load()
        self.memory = Memory()  # what the attempts showed, kept for the next

    def write_model(self, stage: str) -> None:
        assert self.first is not None
        full = task_model(self.family, self.first, self.hints, self.measured, self.steps,
                          dev=self.dev)
        keep = GOAL_CONSTRAINTS[self.family]
        doc = TaskModel(step=full.step, family=full.family, variables=full.variables,
                        constraints=[c for c in full.constraints if c.name in keep],
                        success_criteria=[c for c in full.success_criteria
                                          if c.variable.endswith(GOAL_VARIABLES)])
        self.files.write(doc)
        self.log("model_update", stage, constraints=[c.name for c in doc.constraints])

    def parse(self, ts: Any) -> None:
        self.log("plan", ts.stage, segments=segment(self.manifest, self.arrays))
        self.hints = demo_hints(self.manifest, self.arrays)
        self.measured = dict(self.hints)
        self.write_model(ts.stage)
        dp = self.demo_parse()
        # the path: each phase's goal pose of its part relative to the reference row
        self.log("plan", ts.stage, path=[
            {"kind": p.kind, "part": dp.rows[p.held],
             "ref": None if p.ref is None else dp.rows[p.ref],
             "goal": None if p.goal is None else [round(float(x), 4) for x in p.goal],
             "grasp": [round(float(x), 4) for x in compose([0, 0, 0, 0], p.grasp)]}
            for p in dp.phases])

    def controller(self, view: Any) -> Any:
        dp = self.demo_parse()
        mech = str(self.hints.get("kind", "drawer"))
        kinds = {p.held: kind_of(self.family, p.held, mech) for p in dp.phases}
        goal = next((e for e in self.manifest.events if e.event in GOAL_EVENTS), None)
        return execute(view, dp, self.dynamics, kinds,
                       goal is not None and goal.event in STATE_EVENTS, self.memory)

    def after_attempt(self, data: dict[str, Any]) -> None:
        """The model adapted to what the attempt showed (``self.memory``), logged."""
        adapted = {str(i): {k: (np.round(v, 4).tolist() if isinstance(v, np.ndarray) else v)
                            for k, v in m.items()} for i, m in self.memory.items() if m}
        if adapted and not data.get("success"):
            self.log("model_update", "execution", adapted=adapted)


if __name__ == "__main__":
    sys.exit(main(Agent()))
