"""``BenchInfo``: what ``BenchEnv`` reports beside the observation, typed.

The track plugin reads it as is (``BenchEnv.reset_typed``, ``step_typed``); gymnasium's
``reset``/``step`` return ``as_dict()``, the plain ``info`` dict of gymnasium's API.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class BenchInfo:
    """One step's (or reset's) report."""

    progress: float
    """The bench's ``(stage index + fraction) / stages``, in [0, 1] (1 on success)."""
    success: bool
    stage: str
    """The true key stage, or ``"done"``."""
    value: float | None
    """The magnitude the goal is about (fraction opened, angle turned, depth reached)."""
    contact_force: float
    """Largest normal contact force on the gripper (N)."""
    push_force: float
    """Norm of the net contact force on the gripper (N)."""
    sim_warnings: list[str]
    """MuJoCo warnings raised in this step, plus ``"diverged"`` if it had to be undone."""
    events: list[dict[str, str]]
    """State changes of this step: ``{"event": "grasped" | "released" | "dropped" | …,
    "part": …}``."""
    invalid_action: bool
    """A non-finite action, replaced by "hold still"."""
    action_clipped: bool
    joint_limit: bool
    """The hand at a range limit."""
    step: int

    @property
    def drops(self) -> int:
        """Parts dropped in this step."""
        return sum(1 for e in self.events if e["event"] == "dropped")

    def as_dict(self) -> dict[str, Any]:
        """Gymnasium's ``info``."""
        return {
            "progress": self.progress,
            "success": self.success,
            "stage": self.stage,
            "value": self.value,
            "contact_force": self.contact_force,
            "push_force": self.push_force,
            "sim_warnings": self.sim_warnings,
            "events": self.events,
            "invalid_action": self.invalid_action,
            "action_clipped": self.action_clipped,
            "joint_limit": self.joint_limit,
            "step": self.step,
        }
