"""Task-model baseline for Track 2 (OSVI-WM + task model style).

Uses only ``simhost.client``, ``schemas``, numpy and the standard library; it builds on the
demo-parser image (its perception, primitives and task-model writer).

- From the demonstration it builds an explicit task model: the stages (key-stage labels),
  the goal as relations the demonstration's end state shows (the turn, the opening
  fraction, the stacking yaw of each part on the one below, the inserted depth), the
  success conditions, and the constraints it can measure.
- Each skill (``skills.py``) uses a model of what its motion should do to the part — a
  trajectory the part should follow — compares it with the observations, and adapts when
  they disagree: a blocked direction is turned the other way, a mechanism that does not
  slide is taken to be mirrored, a peg that stays on the rim is searched around. It then
  checks the success conditions and corrects while they do not hold. What an attempt
  learns stays in the model for the next one, and ``task_model.json`` is rewritten with it.
- The tool-use mechanism is read off the instance (a target within reach sits in a well and
  is pressed; one beyond reach is pulled), not copied from the demonstration.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

# In the image the demo parser's modules sit beside this file (/app); in a checkout they
# are in the sibling folder.
_HERE = Path(__file__).resolve().parent
if not (_HERE / "demoparser.py").is_file():
    sys.path.insert(1, str(_HERE.parent / "track2_demoparser"))

import numpy as np  # noqa: E402
from demoparser import Agent as DemoParser  # noqa: E402
from demoparser import demo_hints, main, segment  # noqa: E402
from perception import yaw_of  # noqa: E402
from skills import SKILLS  # noqa: E402


def stack_yaw(man: Any, arrays: dict[str, np.ndarray]) -> float:
    """The yaw between stacked parts at the demonstration's end, modulo 90 degrees: 0 or 45."""
    parts = arrays["obs_parts"][-10:]
    turns = []
    for i in (2, 3):
        if parts[-1, i, 0] < 0.5:
            continue
        d = [yaw_of(r[i, 4:8]) - yaw_of(r[i - 1, 4:8]) for r in parts]
        turns.append(math.atan2(np.mean(np.sin(4 * np.array(d))),
                                np.mean(np.cos(4 * np.array(d)))) / 4)
    if not turns:
        return 0.0
    t = float(np.mean(np.abs(turns)))
    return math.pi / 4 if t > math.pi / 8 else 0.0


class Agent(DemoParser):
    name = "eagc-track2-taskmodel/1"

    def parse(self, ts: Any) -> None:
        self.log("plan", ts.stage, segments=segment(self.manifest, self.arrays))
        self.hints = demo_hints(self.manifest, self.arrays)
        self.model: dict[str, Any] = dict(self.hints)
        self.model.setdefault("turn", self.hints.get("turn", 1.0))
        if self.family == "assembly":
            self.model["stack_yaw"] = stack_yaw(self.manifest, self.arrays)
        if self.family == "tool_use":
            self.model["demo_mechanism"] = self.hints.get("mechanism", "press")
        self.measured = self.model
        self.sync()
        self.write_model(ts.stage)

    def sync(self) -> None:
        """Copy what the skills learned into the task model's measured constraints."""
        m = self.model
        cons: dict[str, Any] = {}
        if "range" in m:
            m["range_measured"] = m["range"]
        if "stack_yaw" in m:
            cons["stack_yaw"] = m["stack_yaw"]
        if "kind" in m:
            cons["mechanism"] = m["kind"]
        m["constraints"] = cons

    def controller(self, view: Any) -> Any:
        return SKILLS[self.family](view, self.model, self.demo_parse())

    def after_attempt(self, data: dict[str, Any]) -> None:
        self.sync()
        self.write_model("execution")


if __name__ == "__main__":
    sys.exit(main(Agent()))
