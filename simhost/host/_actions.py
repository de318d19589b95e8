"""Checking an agent's action against the action spec before it reaches the world.

Every number is checked for dtype, shape, finiteness (NaN/Inf never reach MuJoCo: a NaN
control silently zeroes all controls) and bounds. A named choice may be sent as its index or
its name. Unknown fields are refused; absent fields are left out (the track decides).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from schemas import FieldSpec
from simhost._errors import SimHostError


class ActionError(SimHostError, ValueError):
    """Raised when an action does not match the action spec."""


_FLOATS = {"float32": np.float32, "float64": np.float64}


def _fast_floats(spec: FieldSpec, value: list[Any]) -> np.ndarray | None:
    """The common case, a short list of plain numbers, without numpy's per-call overhead."""
    if len(spec.shape) != 1 or len(value) != spec.shape[0] or spec.choices is not None:
        return None
    low = -math.inf if spec.low is None else spec.low
    high = math.inf if spec.high is None else spec.high
    for x in value:
        if type(x) is not float and type(x) is not int:
            return None
        if not math.isfinite(x):
            raise ActionError(f"{spec.name}: NaN or Inf is not allowed")
        if x < low:
            raise ActionError(f"{spec.name}: below the lower bound {spec.low}")
        if x > high:
            raise ActionError(f"{spec.name}: above the upper bound {spec.high}")
    return np.array(value, dtype=_FLOATS[spec.dtype])


def _check_field(spec: FieldSpec, value: Any) -> Any:
    if spec.dtype == "json":
        raise ActionError(f"{spec.name}: 'json' fields are for observations, not actions")
    if spec.dtype in _FLOATS and type(value) is list:
        fast = _fast_floats(spec, value)
        if fast is not None:
            return fast
    if spec.dtype == "str":
        if not isinstance(value, str) or len(value) > 4096:
            raise ActionError(f"{spec.name}: expected a string of at most 4096 characters")
        if spec.choices is not None and value not in spec.choices:
            raise ActionError(f"{spec.name}: {value!r} is not one of {list(spec.choices)}")
        return value
    if spec.choices is not None and isinstance(value, str):
        if value not in spec.choices:
            raise ActionError(f"{spec.name}: {value!r} is not one of {list(spec.choices)}")
        return spec.choices.index(value)
    if isinstance(value, str | dict) or value is None:
        raise ActionError(f"{spec.name}: expected {spec.dtype} of shape {list(spec.shape)}")
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError) as e:
        raise ActionError(f"{spec.name}: not an array ({e})") from None
    if arr.dtype == object or arr.dtype.kind not in "biuf":
        raise ActionError(f"{spec.name}: expected numbers, got {arr.dtype}")
    if tuple(arr.shape) != tuple(spec.shape):
        raise ActionError(f"{spec.name}: shape {list(arr.shape)}, expected {list(spec.shape)}")
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise ActionError(f"{spec.name}: NaN or Inf is not allowed")
    target = np.dtype(spec.dtype)
    if target.kind in "iu" and arr.dtype.kind == "f":
        if not np.all(arr == np.round(arr)):
            raise ActionError(f"{spec.name}: expected integers")
    if spec.low is not None and np.any(arr < spec.low):
        raise ActionError(f"{spec.name}: below the lower bound {spec.low}")
    if spec.high is not None and np.any(arr > spec.high):
        raise ActionError(f"{spec.name}: above the upper bound {spec.high}")
    if spec.choices is not None and np.any((arr < 0) | (arr >= len(spec.choices))):
        raise ActionError(f"{spec.name}: index out of range 0..{len(spec.choices) - 1}")
    out = arr.astype(target)
    return out.item() if out.ndim == 0 else out


def check_action(
    spec: tuple[FieldSpec, ...],
    action: Mapping[str, Any],
    tensors: Mapping[str, np.ndarray] | None = None,
) -> dict[str, Any]:
    """Return the action with every field checked and converted; raise ActionError."""
    return check_fields({f.name: f for f in spec}, action, tensors)


def check_fields(
    fields: Mapping[str, FieldSpec],
    action: Mapping[str, Any],
    tensors: Mapping[str, np.ndarray] | None = None,
) -> dict[str, Any]:
    """``check_action`` with the spec already keyed by name (the host's per-step path)."""
    merged: Mapping[str, Any] = action
    if tensors:
        merged = dict(action)
        for name, arr in tensors.items():
            if name in merged:
                raise ActionError(f"{name}: given both as JSON and as a tensor")
            merged[name] = arr
    for name in merged:
        if name not in fields:
            unknown = sorted(n for n in merged if n not in fields)
            raise ActionError(f"unknown action field(s) {unknown}; expected {sorted(fields)}")
    return {name: _check_field(fields[name], value) for name, value in merged.items()}
