"""Instance parameters: the tables, sampling around a source, and the distance between instances.

Every family has a fixed table of parameters (``PARAM_TABLES``), each in one of five groups —
``geometry``, ``pose``, ``friction``, ``tools``, ``goal`` — and either continuous (a range)
or categorical (a few choices). An :class:`InstanceParams` holds exactly the table's names.

Sampling (``sample_instance``) draws, per parameter and in table order, two numbers from
``numpy.random.default_rng(seed)``: ``u ~ U(-1, 1)`` and ``s ~ U(0, 1)``. A continuous value
becomes ``source + difficulty * u * (hi - lo)``, reflected back into ``[lo, hi]``; a categorical
value switches, with probability ``0.6 * difficulty``, to another choice picked by ``u``. So
``difficulty = 0`` returns the source itself, and the same seed always gives the same instance.
A *fixed* parameter (the task's identity, e.g. the tool-use mechanism) is copied from a given
source; without a source it is drawn uniformly (by ``s``), the rest varying around the
canonical source.

Distance (``instance_distance``)::

    d(a, b) = sum_g w_g * mean_{p in g} delta_p(a, b) / sum_g w_g

over the groups ``g`` the family has, with ``delta_p = |a_p - b_p| / (hi_p - lo_p)`` for a
continuous parameter and ``delta_p = [a_p != b_p]`` for a categorical one, and weights
``geometry 0.30, pose 0.20, friction 0.15, tools 0.15, goal 0.20``. It lies in [0, 1];
instances of different families are at distance 1.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from typing import Any, Literal, get_args

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from ._errors import InstanceParamsError

Family = Literal["insertion", "rotation", "assembly", "opening", "tool_use"]
FAMILIES: tuple[str, ...] = get_args(Family)
Group = Literal["geometry", "pose", "friction", "tools", "goal"]
GROUPS: tuple[str, ...] = get_args(Group)
GROUP_WEIGHTS: dict[str, float] = {
    "geometry": 0.30, "pose": 0.20, "friction": 0.15, "tools": 0.15, "goal": 0.20,
}
PUBLIC_GROUPS: tuple[str, ...] = ("geometry", "pose", "tools", "goal")
"""Groups a demonstration packet may show; friction is left for the team to infer."""

SWITCH_PROBABILITY = 0.6
"""Chance, at difficulty 1, that a categorical parameter changes from the source's."""

Value = float | int | str | bool


@dataclass(frozen=True)
class ParamSpec:
    """One row of a family's parameter table."""

    name: str
    group: str
    default: Value
    lo: float = 0.0
    hi: float = 0.0
    choices: tuple[Value, ...] = ()
    doc: str = ""
    fixed: bool = False
    """Part of the task's identity: copied from a given source, drawn at random without one."""

    @property
    def categorical(self) -> bool:
        return bool(self.choices)


def _f(name: str, group: str, lo: float, hi: float, default: float, doc: str) -> ParamSpec:
    return ParamSpec(name, group, float(default), float(lo), float(hi), (), doc)


def _c(
    name: str, group: str, choices: tuple[Value, ...], doc: str, *, fixed: bool = False
) -> ParamSpec:
    return ParamSpec(name, group, choices[0], choices=choices, doc=doc, fixed=fixed)


_FRICTION = (
    _f("part", "friction", 0.4, 1.0, 0.7, "sliding friction of the movable parts"),
    _f("surface", "friction", 0.3, 0.9, 0.5, "sliding friction of table and fixtures"),
)

PARAM_TABLES: dict[str, tuple[ParamSpec, ...]] = {
    "insertion": (
        _c("shape", "geometry", ("square", "round", "rect"), "peg cross-section"),
        _f("peg_half", "geometry", 0.012, 0.02, 0.016, "peg half-width (m)"),
        _f("peg_height", "geometry", 0.06, 0.09, 0.075, "peg height (m)"),
        _f("aspect", "geometry", 1.3, 1.8, 1.5, "long/short side ratio of a rect peg"),
        _f("clearance", "geometry", 0.002, 0.006, 0.004, "total hole-peg gap (m)"),
        _f("hole_depth", "geometry", 0.02, 0.035, 0.028, "depth of the hole (m)"),
        _f("peg_x", "pose", -0.16, -0.04, -0.10, "peg position x (m)"),
        _f("peg_y", "pose", -0.12, 0.12, 0.0, "peg position y (m)"),
        _f("peg_yaw", "pose", -0.78, 0.78, 0.0, "peg yaw (rad)"),
        _f("hole_x", "pose", 0.06, 0.18, 0.12, "hole centre x (m)"),
        _f("hole_y", "pose", -0.12, 0.12, 0.0, "hole centre y (m)"),
        _f("hole_yaw", "pose", -0.78, 0.78, 0.0, "hole yaw (rad)"),
        *_FRICTION,
        _f("depth_frac", "goal", 0.5, 0.9, 0.7, "required insertion depth / hole depth"),
    ),
    "rotation": (
        _c("kind", "geometry", ("knob", "valve", "nut"), "rotational mechanism"),
        _f("size", "geometry", 0.8, 1.2, 1.0, "scale of the handle"),
        _f("height", "geometry", 0.04, 0.07, 0.05, "handle height above the table (m)"),
        _f("x", "pose", -0.05, 0.15, 0.05, "axis position x (m)"),
        _f("y", "pose", -0.12, 0.12, 0.0, "axis position y (m)"),
        _f("init_angle", "pose", -1.2, 1.2, 0.0, "initial handle angle (rad)"),
        *_FRICTION,
        _f("damping", "friction", 0.02, 0.2, 0.08, "hinge damping (N m s/rad)"),
        _f("frictionloss", "friction", 0.02, 0.12, 0.05, "hinge dry friction (N m)"),
        _f("turn", "goal", 0.6, 2.0, 1.2, "angle to turn (rad)"),
        _c("direction", "goal", ("ccw", "cw"), "turning direction seen from above"),
    ),
    "assembly": (
        _c("n_parts", "geometry", (2, 3), "number of parts to stack"),
        _f("part_half", "geometry", 0.022, 0.03, 0.026, "half-width of the first part (m)"),
        _f("part_height", "geometry", 0.03, 0.045, 0.036, "height of each part (m)"),
        _f("tray_clearance", "geometry", 0.004, 0.01, 0.006, "tray-part gap (m)"),
        _f("tray_x", "pose", 0.10, 0.16, 0.13, "tray x (m)"),
        _f("tray_y", "pose", -0.08, 0.08, 0.0, "tray y (m)"),
        _f("tray_yaw", "pose", -0.5, 0.5, 0.0, "tray yaw (rad)"),
        _f("p1_x", "pose", -0.20, -0.16, -0.18, "part 1 x (m)"),
        _f("p1_y", "pose", 0.10, 0.16, 0.13, "part 1 y (m)"),
        _f("p1_yaw", "pose", -0.6, 0.6, 0.0, "part 1 yaw (rad)"),
        _f("p2_x", "pose", -0.20, -0.16, -0.18, "part 2 x (m)"),
        _f("p2_y", "pose", -0.16, -0.10, -0.13, "part 2 y (m)"),
        _f("p2_yaw", "pose", -0.6, 0.6, 0.0, "part 2 yaw (rad)"),
        _f("p3_x", "pose", -0.07, -0.03, -0.05, "part 3 x (m)"),
        _f("p3_y", "pose", 0.10, 0.16, 0.13, "part 3 y (m)"),
        _f("p3_yaw", "pose", -0.6, 0.6, 0.0, "part 3 yaw (rad)"),
        *_FRICTION,
    ),
    "opening": (
        _c("kind", "geometry", ("drawer", "sliding_cover", "swivel_lid"), "mechanism"),
        _f("travel", "geometry", 0.06, 0.12, 0.09, "slide travel (m)"),
        _f("swing", "geometry", 0.8, 1.4, 1.1, "swivel range (rad)"),
        _f("handle_scale", "geometry", 0.8, 1.2, 1.0, "scale of the handle"),
        _f("x", "pose", 0.04, 0.12, 0.08, "mechanism x (m)"),
        _f("y", "pose", -0.1, 0.1, 0.0, "mechanism y (m)"),
        _f("yaw", "pose", -0.4, 0.4, 0.0, "mechanism yaw (rad)"),
        *_FRICTION,
        _f("damping", "friction", 1.0, 6.0, 3.0, "joint damping (N s/m)"),
        _f("frictionloss", "friction", 0.3, 1.5, 0.8, "joint dry friction (N)"),
        _c("mode", "goal", ("open", "close"), "open from closed, or close from open"),
        _f("goal_frac", "goal", 0.5, 1.0, 0.8, "target (open) or start (close) fraction"),
    ),
    "tool_use": (
        _c("mechanism", "geometry", ("press", "pull"), "press a sunken button / pull a puck",
           fixed=True),
        _f("tool_length", "geometry", 0.12, 0.16, 0.14, "length of the useful tool (m)"),
        _f("well_depth", "geometry", 0.05, 0.08, 0.065, "depth of the button well (m)"),
        _f("puck_radius", "geometry", 0.02, 0.03, 0.025, "radius of the puck (m)"),
        _f("target_u", "pose", 0.0, 1.0, 0.5, "target x within its region (0..1)"),
        _f("target_v", "pose", 0.0, 1.0, 0.5, "target y within its region (0..1)"),
        _f("tool_dx", "pose", -0.02, 0.02, 0.0, "tool offset from its slot x (m)"),
        _f("tool_dy", "pose", -0.02, 0.02, 0.0, "tool offset from its slot y (m)"),
        _f("tool_yaw", "pose", -0.4, 0.4, 0.0, "tool yaw offset (rad)"),
        *_FRICTION,
        _c("tool_slot", "tools", (0, 1), "slot holding the useful tool"),
        _c("distractor", "tools", (False, True), "a second, too short tool is present"),
        _c("tool_shape", "tools", ("round", "square"), "shaft cross-section"),
        _f("goal_u", "goal", 0.0, 1.0, 0.5, "pull: goal line x within its region (0..1)"),
    ),
}


class InstanceParams(BaseModel):
    """One bench instance: family plus the values of its parameter table, grouped.

    JSON round trip: ``InstanceParams.model_validate_json(p.model_dump_json()) == p``.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    version: Literal["eagc-bench/v1"] = "eagc-bench/v1"
    family: Family
    geometry: dict[str, Value] = Field(description="Shapes and sizes.")
    pose: dict[str, Value] = Field(description="Where parts and fixtures stand.")
    friction: dict[str, Value] = Field(description="Surface and joint friction.")
    tools: dict[str, Value] = Field(default_factory=dict, description="Tool availability.")
    goal: dict[str, Value] = Field(default_factory=dict, description="Goal parameters.")

    @model_validator(mode="after")
    def _check_table(self) -> InstanceParams:
        for group in GROUPS:
            specs = {s.name: s for s in PARAM_TABLES[self.family] if s.group == group}
            given: dict[str, Value] = getattr(self, group)
            for key in given:
                if key not in specs:
                    hint = difflib.get_close_matches(key, list(specs), n=1)
                    extra = f" Did you mean {hint[0]!r}?" if hint else ""
                    raise InstanceParamsError(
                        f"{self.family}: unknown {group} parameter {key!r}.{extra} "
                        f"Allowed: {sorted(specs)}"
                    )
            for name, spec in specs.items():
                if name not in given:
                    raise InstanceParamsError(
                        f"{self.family}: missing {group} parameter {name!r} ({spec.doc})"
                    )
                _check_value(self.family, spec, given[name])
        return self

    def value(self, name: str) -> Value:
        """The value of parameter ``name`` whatever its group."""
        for group in GROUPS:
            values: dict[str, Value] = getattr(self, group)
            if name in values:
                return values[name]
        raise KeyError(f"{self.family} has no parameter {name!r}")

    def f(self, name: str) -> float:
        """The value of a continuous parameter as a float."""
        return float(self.value(name))  # type: ignore[arg-type]

    def public(self) -> dict[str, Any]:
        """The parameters a demonstration packet may show (no friction)."""
        data = self.model_dump(mode="json")
        for group in GROUPS:
            if group not in PUBLIC_GROUPS:
                data.pop(group, None)
        return data


def _check_value(family: str, spec: ParamSpec, value: Value) -> None:
    where = f"{family}.{spec.group}.{spec.name}"
    if spec.categorical:
        if value not in spec.choices or type(value) is not type(spec.choices[0]):
            raise InstanceParamsError(f"{where} = {value!r}; choose one of {list(spec.choices)}")
        return
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InstanceParamsError(f"{where} must be a number, got {value!r}")
    if not math.isfinite(value) or not spec.lo - 1e-9 <= value <= spec.hi + 1e-9:
        raise InstanceParamsError(f"{where} = {value!r} is outside [{spec.lo}, {spec.hi}]")


def _check_family(family: str) -> None:
    if family not in FAMILIES:
        hint = difflib.get_close_matches(str(family), FAMILIES, n=1)
        extra = f" Did you mean {hint[0]!r}?" if hint else ""
        raise InstanceParamsError(f"unknown family {family!r}.{extra} Families: {FAMILIES}")


def _build(family: str, values: dict[str, Value]) -> InstanceParams:
    groups: dict[str, dict[str, Value]] = {g: {} for g in GROUPS}
    for spec in PARAM_TABLES[family]:
        groups[spec.group][spec.name] = values[spec.name]
    return InstanceParams(family=family, **groups)  # type: ignore[arg-type]


def default_source(family: str) -> InstanceParams:
    """The canonical source instance of ``family`` (every parameter at its default)."""
    _check_family(family)
    return _build(family, {s.name: s.default for s in PARAM_TABLES[family]})


def _reflect(x: float, lo: float, hi: float) -> float:
    span = hi - lo
    if span <= 0:
        return lo
    t = (x - lo) % (2 * span)
    return lo + (t if t <= span else 2 * span - t)


def sample_instance(
    family: str,
    seed: int,
    *,
    source: InstanceParams | None = None,
    difficulty: float = 0.5,
) -> InstanceParams:
    """Draw a hidden instance of ``family`` around ``source`` (default: the canonical source).

    Args:
      family: one of ``FAMILIES``.
      seed: the only source of randomness (``numpy.random.default_rng(seed)``).
      source: the demonstrated instance to vary around; must be of ``family``.
      difficulty: in [0, 1]; 0 returns the source, 1 spreads over whole ranges.

    Returns:
      A validated :class:`InstanceParams`.
    """
    _check_family(family)
    if not 0.0 <= difficulty <= 1.0 or not math.isfinite(difficulty):
        raise InstanceParamsError(f"difficulty must lie in [0, 1], got {difficulty!r}")
    given = source
    if source is None:
        source = default_source(family)
    elif source.family != family:
        raise InstanceParamsError(f"source is a {source.family} instance, not {family}")
    rng = np.random.default_rng(seed)
    values: dict[str, Value] = {}
    for spec in PARAM_TABLES[family]:
        u = float(rng.uniform(-1.0, 1.0))
        s = float(rng.random())
        src = source.value(spec.name)
        if spec.fixed:
            if given is None:
                src = spec.choices[min(int(s * len(spec.choices)), len(spec.choices) - 1)]
            values[spec.name] = src
        elif spec.categorical:
            others = [c for c in spec.choices if c != src]
            if others and s < SWITCH_PROBABILITY * difficulty:
                src = others[min(int((u + 1.0) / 2.0 * len(others)), len(others) - 1)]
            values[spec.name] = src
        else:
            x = float(src) + difficulty * u * (spec.hi - spec.lo)  # type: ignore[arg-type]
            values[spec.name] = round(_reflect(x, spec.lo, spec.hi), 6)
    return _build(family, values)


def instance_distance(a: InstanceParams, b: InstanceParams) -> float:
    """How far instance ``b`` is from ``a``, in [0, 1] (formula in the module docstring)."""
    if a.family != b.family:
        return 1.0
    per_group: dict[str, list[float]] = {}
    for spec in PARAM_TABLES[a.family]:
        va, vb = a.value(spec.name), b.value(spec.name)
        if spec.categorical:
            delta = 0.0 if va == vb else 1.0
        else:
            delta = abs(float(va) - float(vb)) / (spec.hi - spec.lo)  # type: ignore[arg-type]
        per_group.setdefault(spec.group, []).append(min(1.0, delta))
    total = sum(GROUP_WEIGHTS[g] for g in per_group)
    score = sum(GROUP_WEIGHTS[g] * float(np.mean(v)) for g, v in per_group.items())
    return float(min(1.0, max(0.0, score / total)))
