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
    "nothing_there",
    "ids_not_accepted",
)
"""Every failure reason ``info["action_result"]["reason"]`` may carry (``nothing_there``:
a pixel on no instance, e.g. a wall or the floor; ``ids_not_accepted``: an id where the
split takes pixels)."""

Pixel = tuple[int, int]
"""A pixel ``(u, v)`` of the camera frame: column from the left, row from the top."""


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


def make_pixel_action(
    primitive: str, *, forward: float = 0.0, turn: float = 0.0,
    target_px: Pixel | None = None, tool_px: Pixel | None = None,
) -> dict[str, Any]:
    """An action dict for a ``HouseEnv`` that takes pixels (``actions_by="pixel"``), e.g.
    ``make_pixel_action("pick", target_px=(120, 140))``; a ``None`` pixel is left out."""
    action = make_action(primitive, forward=forward, turn=turn)
    del action["target"], action["tool"]
    for key, px in (("target_px", target_px), ("tool_px", tool_px)):
        if px is not None:
            action[key] = np.array(px, dtype=np.int32)
    return action


def _as_int(value: Any) -> int | None:
    try:
        arr = np.asarray(value)
        if arr.size != 1 or arr.dtype.kind not in "iub":
            return None
        return int(arr.reshape(()))
    except (TypeError, ValueError):
        return None


def _as_pixel(value: Any, size: tuple[int, int]) -> Pixel | None:
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        return None
    if arr.shape != (2,) or arr.dtype.kind not in "iuf":
        return None
    if arr.dtype.kind == "f" and not (np.all(np.isfinite(arr)) and np.all(arr == np.round(arr))):
        return None
    u, v = (int(x) for x in arr)
    width, height = size
    return (u, v) if 0 <= u < width and 0 <= v < height else None


def parse_pixel_action(
    action: Any, size: tuple[int, int]
) -> tuple[str, float, float, Pixel | None, Pixel | None] | ActionResult:
    """``parse_action`` for a split that takes pixels: ``target_px`` and ``tool_px`` (each
    ``[u, v]`` within ``size`` = (width, height), or absent: None) instead of ids. An action
    that carries ``target`` or ``tool`` is refused (``ids_not_accepted``)."""
    parsed = parse_action(action, ids=False)
    if isinstance(parsed, ActionResult):
        return parsed
    primitive, forward, turn, _, _ = parsed
    assert isinstance(action, Mapping)
    if "target" in action or "tool" in action:
        return ActionResult(primitive, False, "ids_not_accepted")
    pixels: list[Pixel | None] = []
    for key in ("target_px", "tool_px"):
        px = None if action.get(key) is None else _as_pixel(action[key], size)
        if action.get(key) is not None and px is None:
            return ActionResult(primitive, False, "invalid_action")
        pixels.append(px)
    return primitive, forward, turn, pixels[0], pixels[1]


def parse_action(
    action: Any, *, ids: bool = True
) -> tuple[str, float, float, int, int] | ActionResult:
    """Validate an action; a bad one comes back as a failed ``ActionResult``.

    Non-finite ``move`` values are refused (``non_finite_action``) whatever the primitive;
    finite ones are clipped to [-1, 1]. ``ids=False``: ``target`` and ``tool`` are not read
    (both come back 0).
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
    if not ids:
        target, tool = 0, 0
    else:
        target, tool = _as_int(action.get("target", 0)), _as_int(action.get("tool", 0))
    if target is None or tool is None or not (0 <= target < MAX_IDS and 0 <= tool < MAX_IDS):
        return ActionResult(primitive, False, "invalid_action")
    forward, turn = (float(v) for v in np.clip(move, -1.0, 1.0))
    return primitive, forward, turn, target, tool
