"""``HouseInfo``: what ``HouseEnv`` reports beside the observation, typed.

The track plugin reads it as is (``HouseEnv.reset_typed``, ``step_typed``,
``observe_typed``); gymnasium's ``reset``/``step``/``observe`` return ``as_dict()``, the
plain ``info`` dict of gymnasium's API.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ._actions import ActionResult

if TYPE_CHECKING:  # _sensors loads MuJoCo
    from ._sensors import Detection


@dataclass(frozen=True)
class HouseInfo:
    """One step's (or reset's) report."""

    action_result: ActionResult
    """The last primitive: ``ok``, ``reason`` (why it failed), ``primitive``, ``collided``."""
    detections: tuple[Detection, ...]
    """Every detection (nearest first), not cut to the observation's rows."""
    room: int
    """The room the robot knows it is in (-1: it does not know at this step)."""
    room_type: str | None
    """The type of ``room``; None when ``room`` is -1."""
    held: int
    """Instance id of the held item; -1 when the hand is empty (``held="flag"``: 1 when
    the hand holds something, else 0)."""
    step: int
    """Primitives run since reset."""
    sim_warnings: Mapping[str, int]
    """MuJoCo warning counters by name (``HouseSim.warnings``)."""
    task_satisfied: bool | None = None
    """Whether the reset's task holds (None: no task was given)."""

    @property
    def collided(self) -> bool:
        """Whether the last move stopped on contact."""
        return self.action_result.collided

    def as_dict(self) -> dict[str, Any]:
        """Gymnasium's ``info``: plain JSON-friendly values."""
        r = self.action_result
        info: dict[str, Any] = {
            "action_result": {"ok": r.ok, "reason": r.reason, "primitive": r.primitive},
            "collided": r.collided,
            "detections": [d.to_dict() for d in self.detections],
            "room": {"id": self.room, "type": self.room_type},
            "held": self.held,
            "step": self.step,
            "sim_warnings": self.sim_warnings,
        }
        if self.task_satisfied is not None:
            info["task_satisfied"] = self.task_satisfied
        return info
