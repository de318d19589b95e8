"""Primitive names, failure reasons, and action validation (numpy only)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._catalogue import MAX_IDS

PRIMITIVES: tuple[str, ...] = ("noop", "move", "open", "close", "pick", "place", "use", "done")
"""Primitive names, in the order of the ``primitive`` action index."""

REASONS: tuple[str, ...] = (
    "invalid_action",
    "non_finite_action",
    "unknown_id",
    "not_visible",
    "out_of_reach",
    "not_openable",
    "locked",
    "unavailable",
    "already_open",
    "already_closed",
    "blocked_by_robot",
    "hand_full",
    "hand_empty",
    "not_pickable",
    "not_a_receptacle",
    "container_closed",
    "receptacle_full",
    "tool_not_held",
    "not_a_tool",
    "not_applicable",
    "lacks_affordance",
    "no_effect",
)
"""Every failure reason ``info["action_result"]["reason"]`` may carry."""


@dataclass(frozen=True)
class ActionResult:
    """The outcome of one primitive."""

    primitive: str
    ok: bool
    reason: str = ""
    """Empty on success; one of ``REASONS`` on failure; ``collided`` for a stopped move."""
    collided: bool = False

    def to_dict(self) -> dict[str, Any]:
        """The ``info["action_result"]`` form."""
        return {
            "ok": self.ok,
            "reason": self.reason,
            "primitive": self.primitive,
            "collided": self.collided,
        }


def make_action(
    primitive: str, *, forward: float = 0.0, turn: float = 0.0, target: int = 0, tool: int = 0
) -> dict[str, Any]:
    """An action dict for ``HouseEnv.step`` (e.g. ``make_action("pick", target=12)``)."""
    if primitive not in PRIMITIVES:
        raise ValueError(f"unknown primitive {primitive!r}; one of {PRIMITIVES}")
    return {
        "primitive": PRIMITIVES.index(primitive),
        "move": np.array([forward, turn], dtype=np.float32),
        "target": target,
        "tool": tool,
    }


def _as_int(value: Any) -> int | None:
    try:
        arr = np.asarray(value)
        if arr.size != 1 or arr.dtype.kind not in "iub":
            return None
        return int(arr.reshape(()))
    except (TypeError, ValueError):
        return None


def parse_action(action: Any) -> tuple[str, float, float, int, int] | ActionResult:
    """Validate an action; a bad one comes back as a failed ``ActionResult``.

    Non-finite ``move`` values are refused (``non_finite_action``) whatever the primitive;
    finite ones are clipped to [-1, 1].
    """
    if not isinstance(action, Mapping):
        return ActionResult("invalid", False, "invalid_action")
    raw = action.get("primitive")
    index = PRIMITIVES.index(raw) if isinstance(raw, str) and raw in PRIMITIVES else _as_int(raw)
    if index is None or not 0 <= index < len(PRIMITIVES):
        return ActionResult("invalid", False, "invalid_action")
    primitive = PRIMITIVES[index]
    try:
        move = np.asarray(action.get("move", (0.0, 0.0)), dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        return ActionResult(primitive, False, "invalid_action")
    if move.shape != (2,):
        return ActionResult(primitive, False, "invalid_action")
    if not np.all(np.isfinite(move)):
        return ActionResult(primitive, False, "non_finite_action")
    target, tool = _as_int(action.get("target", 0)), _as_int(action.get("tool", 0))
    if target is None or tool is None or not (0 <= target < MAX_IDS and 0 <= tool < MAX_IDS):
        return ActionResult(primitive, False, "invalid_action")
    forward, turn = (float(v) for v in np.clip(move, -1.0, 1.0))
    return primitive, forward, turn, target, tool
