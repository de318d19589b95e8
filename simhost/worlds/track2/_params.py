"""Instance parameters: the tables, sampling around a source, and the distance between instances.

Every family has a fixed table of parameters (``PARAM_TABLES``), each in one of five groups —
``geometry``, ``pose``, ``friction`` (dynamics: friction, damping, mass), ``tools``, ``goal``
— and either continuous (a range) or categorical (a few choices). An :class:`InstanceParams`
holds exactly the table's names. Each row has two ranges: the *wide* range of the official
splits (``lo``/``hi``, ``choices``) and the narrower *dev* range of the public ``dev`` split
(``dev``), today's level; new shapes exist only in the wide choices.

Sampling (``sample_instance``) draws, per parameter and in table order, three numbers from
``numpy.random.default_rng(seed)``: ``u ~ U(-1, 1)``, ``s ~ U(0, 1)`` and ``m ~ U(0, 1)``.
With a :class:`~simhost.worlds.track2.VariationConfig` ``v``:

- a continuous value becomes ``source + v.difficulty * u * (hi - lo)``, reflected back into
  the split's range;
- a categorical value switches, with probability ``v.switch_probability * v.difficulty``, to
  another allowed choice picked by ``u``;
- a *fixed* parameter (the task's identity, e.g. the tool-use mechanism) is copied from a
  given source (drawn uniformly by ``s`` without one), and a *goal* parameter is copied from
  the source when ``v.goal_from_source`` (the goal is "the same turn, the same fraction" as
  the demonstration); either kind marked ``switchable`` (the tool mechanism, the turning
  direction) still switches, with probability ``v.mechanism_switch`` (drawn by ``m``).

So ``difficulty = 0`` (and no mechanism switch) returns the source itself, and the same seed
always gives the same instance.

Distance (``instance_distance``)::

    d(a, b) = sum_g w_g * mean_{p in g} delta_p(a, b) / sum_g w_g

over the groups ``g`` the family has, with ``delta_p = |a_p - b_p| / (hi_p - lo_p)`` (the
wide range) for a continuous parameter and ``delta_p = [a_p != b_p]`` for a categorical
one, and weights ``geometry 0.30, pose 0.20, friction 0.15, tools 0.15, goal 0.20``. It lies
in [0, 1]; instances of different families are at distance 1.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from ._config import VariationConfig
from ._errors import InstanceParamsError

Family = Literal["insertion", "rotation", "assembly", "opening", "tool_use"]
FAMILIES: tuple[str, ...] = get_args(Family)
Group = Literal["geometry", "pose", "friction", "tools", "goal"]
GROUPS: tuple[str, ...] = get_args(Group)
GROUP_WEIGHTS: dict[str, float] = {
    "geometry": 0.30, "pose": 0.20, "friction": 0.15, "tools": 0.15, "goal": 0.20,
}

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
    dev: tuple[Value, ...] | None = None
    """The ``dev`` split's range ``(lo, hi)`` or choices; ``None``: the same as the wide one."""
    switchable: bool = False
    """A fixed or goal parameter that may still switch (``VariationConfig.mechanism_switch``)."""

    @property
    def categorical(self) -> bool:
        return bool(self.choices)

    def allowed(self, wide: bool) -> tuple[Value, ...]:
        """The choices of a categorical parameter in the wide or the dev ranges."""
        return self.choices if wide or self.dev is None else self.dev

    def bounds(self, wide: bool) -> tuple[float, float]:
        """``(lo, hi)`` of a continuous parameter in the wide or the dev ranges."""
        if wide or self.dev is None:
            return self.lo, self.hi
        return float(self.dev[0]), float(self.dev[1])  # type: ignore[arg-type]


def _f(name: str, group: str, lo: float, hi: float, default: float, doc: str,
       dev: tuple[float, float] | None = None) -> ParamSpec:
    return ParamSpec(name, group, float(default), float(lo), float(hi), (), doc, dev=dev)


def _c(name: str, group: str, choices: tuple[Value, ...], doc: str, *, fixed: bool = False,
       dev: tuple[Value, ...] | None = None, switchable: bool = False) -> ParamSpec:
    return ParamSpec(name, group, choices[0], choices=choices, doc=doc, fixed=fixed, dev=dev,
                     switchable=switchable)


def _friction(density: float) -> tuple[ParamSpec, ...]:
    return (
        _f("part", "friction", 0.3, 1.1, 0.7, "sliding friction of the movable parts",
           (0.4, 1.0)),
        _f("surface", "friction", 0.2, 1.0, 0.5, "sliding friction of table and fixtures",
           (0.3, 0.9)),
        _f("density", "friction", 0.5 * density, 2.0 * density, density,
           "density of the movable parts (kg/m^3)", (density, density)),
    )


PARAM_TABLES: dict[str, tuple[ParamSpec, ...]] = {
    "insertion": (
        _c("shape", "geometry", ("square", "round", "rect", "hex"), "peg cross-section",
           dev=("square", "round", "rect")),
        _f("peg_half", "geometry", 0.011, 0.021, 0.016, "peg half-width (m)", (0.012, 0.02)),
        _f("peg_height", "geometry", 0.058, 0.092, 0.075, "peg height (m)", (0.06, 0.09)),
        _f("aspect", "geometry", 1.25, 1.85, 1.5, "long/short side ratio of a rect peg",
           (1.3, 1.8)),
        _f("clearance", "geometry", 0.0005, 0.003, 0.0025, "total hole-peg gap (m)",
           (0.002, 0.006)),
        _f("hole_depth", "geometry", 0.018, 0.036, 0.028, "depth of the hole (m)",
           (0.02, 0.035)),
        _f("peg_x", "pose", -0.16, -0.04, -0.10, "peg position x (m)"),
        _f("peg_y", "pose", -0.12, 0.12, 0.0, "peg position y (m)"),
        _f("peg_yaw", "pose", -0.78, 0.78, 0.0, "peg yaw (rad)"),
        _f("hole_x", "pose", 0.06, 0.18, 0.12, "hole centre x (m)"),
        _f("hole_y", "pose", -0.12, 0.12, 0.0, "hole centre y (m)"),
        _f("hole_yaw", "pose", -0.78, 0.78, 0.0, "hole yaw (rad)"),
        *_friction(600.0),
        _f("depth_frac", "goal", 0.5, 0.9, 0.7, "required insertion depth / hole depth"),
    ),
    "rotation": (
        _c("kind", "geometry", ("knob", "valve", "nut"), "rotational mechanism"),
        _f("size", "geometry", 0.75, 1.25, 1.0, "scale of the handle", (0.8, 1.2)),
        _f("height", "geometry", 0.035, 0.075, 0.05, "handle height above the table (m)",
           (0.04, 0.07)),
        _f("x", "pose", -0.05, 0.15, 0.05, "axis position x (m)"),
        _f("y", "pose", -0.12, 0.12, 0.0, "axis position y (m)"),
        _f("init_angle", "pose", -1.5, 1.5, 0.0, "initial handle angle (rad)", (-1.2, 1.2)),
        *_friction(800.0),
        _f("damping", "friction", 0.02, 0.3, 0.08, "hinge damping (N m s/rad)", (0.02, 0.2)),
        _f("frictionloss", "friction", 0.02, 0.2, 0.05, "hinge dry friction (N m)",
           (0.02, 0.12)),
        _f("turn", "goal", 0.5, 2.2, 1.2, "angle to turn (rad)", (0.6, 2.0)),
        _c("direction", "goal", ("ccw", "cw"),
           "turning direction seen from above; a stop blocks the other way", switchable=True),
    ),
    "assembly": (
        _c("n_parts", "geometry", (2, 3), "number of parts to stack"),
        _f("part_half", "geometry", 0.021, 0.031, 0.026, "half-width of the first part (m)",
           (0.022, 0.03)),
        _f("part_height", "geometry", 0.028, 0.046, 0.036, "height of each part (m)",
           (0.03, 0.045)),
        _f("tray_clearance", "geometry", 0.002, 0.01, 0.006, "tray-part gap (m)",
           (0.004, 0.01)),
        _f("tray_x", "pose", 0.10, 0.16, 0.13, "tray x (m)"),
        _f("tray_y", "pose", -0.08, 0.08, 0.0, "tray y (m)"),
        _f("tray_yaw", "pose", -0.7, 0.7, 0.0, "tray yaw (rad)", (-0.5, 0.5)),
        _f("p1_x", "pose", -0.20, -0.16, -0.18, "part 1 x (m)"),
        _f("p1_y", "pose", 0.10, 0.16, 0.13, "part 1 y (m)"),
        _f("p1_yaw", "pose", -0.7, 0.7, 0.0, "part 1 yaw (rad)", (-0.6, 0.6)),
        _f("p2_x", "pose", -0.20, -0.16, -0.18, "part 2 x (m)"),
        _f("p2_y", "pose", -0.16, -0.10, -0.13, "part 2 y (m)"),
        _f("p2_yaw", "pose", -0.7, 0.7, 0.0, "part 2 yaw (rad)", (-0.6, 0.6)),
        _f("p3_x", "pose", -0.07, -0.03, -0.05, "part 3 x (m)"),
        _f("p3_y", "pose", 0.10, 0.16, 0.13, "part 3 y (m)"),
        _f("p3_yaw", "pose", -0.7, 0.7, 0.0, "part 3 yaw (rad)", (-0.6, 0.6)),
        *_friction(500.0),
        _c("stack", "goal", ("square", "diagonal"),
           "each part set square on the one below, or turned 45 degrees", fixed=True,
           dev=("square",)),
    ),
    "opening": (
        _c("kind", "geometry", ("drawer", "sliding_cover", "swivel_lid"), "mechanism"),
        _c("mirror", "geometry", (False, True),
           "a cover sliding, or a lid hinged, the other way (drawers ignore it)", dev=(False,),
           fixed=True, switchable=True),
        _f("travel", "geometry", 0.05, 0.13, 0.09, "slide travel (m)", (0.06, 0.12)),
        _f("swing", "geometry", 0.7, 1.5, 1.1, "swivel range (rad)", (0.8, 1.4)),
        _f("handle_scale", "geometry", 0.75, 1.25, 1.0, "scale of the handle", (0.8, 1.2)),
        _f("x", "pose", 0.04, 0.12, 0.08, "mechanism x (m)"),
        _f("y", "pose", -0.1, 0.1, 0.0, "mechanism y (m)"),
        _f("yaw", "pose", -0.5, 0.5, 0.0, "mechanism yaw (rad)", (-0.4, 0.4)),
        _f("start_frac", "pose", 0.0, 0.3, 0.0,
           "start this far from the start end (open: from closed; close: from fully open)",
           (0.0, 0.0)),
        *_friction(600.0),
        _f("damping", "friction", 1.0, 8.0, 3.0, "joint damping (N s/m)", (1.0, 6.0)),
        _f("frictionloss", "friction", 0.3, 2.0, 0.8, "joint dry friction (N)", (0.3, 1.5)),
        _c("mode", "goal", ("open", "close"), "open from (nearly) closed, or close from open"),
        _f("goal_frac", "goal", 0.5, 1.0, 0.8,
           "how far to move: open to this fraction, or close to 1 minus it"),
    ),
    "tool_use": (
        _c("mechanism", "geometry", ("press", "pull"), "press a sunken button / pull a puck",
           fixed=True, switchable=True),
        _f("tool_length", "geometry", 0.115, 0.165, 0.14, "length of the useful tool (m)",
           (0.12, 0.16)),
        _f("well_depth", "geometry", 0.045, 0.085, 0.065, "depth of the button well (m)",
           (0.05, 0.08)),
        _f("puck_radius", "geometry", 0.018, 0.032, 0.025, "radius of the puck (m)",
           (0.02, 0.03)),
        _f("target_u", "pose", 0.0, 1.0, 0.5, "target x within its region (0..1)"),
        _f("target_v", "pose", 0.0, 1.0, 0.5, "target y within its region (0..1)"),
        _f("tool_dx", "pose", -0.025, 0.025, 0.0, "tool offset from its slot x (m)",
           (-0.02, 0.02)),
        _f("tool_dy", "pose", -0.025, 0.025, 0.0, "tool offset from its slot y (m)",
           (-0.02, 0.02)),
        _f("tool_yaw", "pose", -0.5, 0.5, 0.0, "tool yaw offset (rad)", (-0.4, 0.4)),
        *_friction(600.0),
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

    version: Literal["eagc-bench/v2"] = "eagc-bench/v2"
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


def _check_value(family: str, spec: ParamSpec, value: Value) -> None:
    where = f"{family}.{spec.group}.{spec.name}"
    if spec.categorical:
        if value not in spec.choices or type(value) is not type(spec.choices[0]):
            raise InstanceParamsError(f"{where} = {value!r}; choose one of {list(spec.choices)}")
        return
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InstanceParamsError(f"{where} must be a number, got {value!r}")
    lo, hi = spec.bounds(True)
    if spec.dev is not None:  # either split's range is valid
        lo, hi = min(lo, spec.bounds(False)[0]), max(hi, spec.bounds(False)[1])
    if not math.isfinite(value) or not lo - 1e-9 <= value <= hi + 1e-9:
        raise InstanceParamsError(f"{where} = {value!r} is outside [{lo}, {hi}]")


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


def _pick(choices: list[Value], u: float) -> Value:
    return choices[min(int((u + 1.0) / 2.0 * len(choices)), len(choices) - 1)]


def sample_instance(
    family: str,
    seed: int,
    *,
    source: InstanceParams | None = None,
    difficulty: float | None = None,
    variation: VariationConfig | None = None,
) -> InstanceParams:
    """Draw a hidden instance of ``family`` around ``source`` (default: the canonical source).

    Args:
      family: one of ``FAMILIES``.
      seed: the only source of randomness (``numpy.random.default_rng(seed)``).
      source: the demonstrated instance to vary around; must be of ``family``.
      difficulty: overrides ``variation.difficulty`` (in [0, 1]; 0 returns the source).
      variation: how to vary (default: the ``dev`` split's, today's level).

    Returns:
      A validated :class:`InstanceParams`.
    """
    _check_family(family)
    v = variation or VariationConfig()
    if difficulty is not None:
        if not math.isfinite(difficulty) or not 0.0 <= difficulty <= 1.0:
            raise InstanceParamsError(f"difficulty must lie in [0, 1], got {difficulty!r}")
        v = v.model_copy(update={"difficulty": float(difficulty)})
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
        m = float(rng.random())
        src = source.value(spec.name)
        allowed = list(spec.allowed(v.wide))
        if spec.fixed or (spec.group == "goal" and v.goal_from_source):
            if spec.fixed and given is None:
                src = allowed[min(int(s * len(allowed)), len(allowed) - 1)]
            others = [c for c in allowed if c != src]
            if spec.switchable and others and m < v.mechanism_switch:
                src = _pick(others, u)
            values[spec.name] = src
        elif spec.categorical:
            others = [c for c in allowed if c != src]
            if src not in allowed:  # a wide-only choice met in the dev ranges
                src = _pick(allowed, u)
            elif others and s < v.switch_probability * v.difficulty:
                src = _pick(others, u)
            values[spec.name] = src
        else:
            lo, hi = spec.bounds(v.wide)
            x = float(src) + v.difficulty * u * (hi - lo)  # type: ignore[arg-type]
            values[spec.name] = round(_reflect(x, lo, hi), 6)
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
