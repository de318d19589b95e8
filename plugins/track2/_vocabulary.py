"""Track 2's words on the protocol page (``Track2.vocabulary``): the demonstration packet's
arrays, which ``parts`` row each annotation's part names, the task-model names per family
(from the truths of sampled instances: what ``task_model.json`` is compared with), the
constraints' value types and units, and how values are compared."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from plugins._base import TrackPlugin
from plugins.track2 import _scoring
from plugins.track2._scenario import Track2Scenario

#: Instances sampled (seeds and indexes 0..SAMPLES-1): one of each family, as the index
#: balances them.
SAMPLES = 5
#: The unit of each numeric constraint (the code holds values, not units); a test checks
#: that every numeric constraint of every family has one.
UNITS: dict[str, str] = {
    "clearance": "m", "yaw_symmetry": "rad", "hole_depth": "m", "max_grip_width": "m",
    "grasp_symmetry": "rad", "turn_angle": "rad", "angle_tolerance": "rad",
    "n_parts": "count", "part_half_widths": "m", "part_height": "m",
    "tray_clearance": "m", "xy_tolerance": "m", "yaw_tolerance": "rad", "stack_yaw": "rad",
    "joint_range": "m (prismatic) or rad (revolute)",
    "opening_tolerance": "fraction of the range (0 closed, 1 open)",
    "tool_slot": "index (0 or 1)", "tool_length": "m", "well_depth": "m",
    "well_width": "m", "press_depth": "m", "goal_tolerance": "m",
}


def variants(family: str) -> list[Any]:
    """The family's source instance and, for each choice of a parameter with choices,
    the source with that one choice changed (every kind of instance at least once)."""
    return [params for _, params in labelled_variants(family)]


def labelled_variants(family: str) -> list[tuple[str, Any]]:
    """``variants`` with what each changes (``""`` for the source, else
    ``"name: choice"``)."""
    from simhost.worlds.track2 import PARAM_TABLES, InstanceParams, default_source

    source = default_source(family)
    out: list[tuple[str, Any]] = [("", source)]
    for spec in PARAM_TABLES[family]:
        for choice in spec.choices[1:]:
            values = source.model_dump()
            values[spec.group][spec.name] = choice
            out.append((f"{spec.name}: {choice}", InstanceParams.model_validate(values)))
    return out


def part_rows() -> tuple[dict[str, tuple[str, ...]], dict[str, dict[str, set[str]]]]:
    """Each family's ``parts`` rows in order, and family → part name of the annotations
    and of the truth's variables → the ``parts`` rows it is, found by playing the
    scripted expert on every variant (``dev``, exact): a loose part by its body, a part
    being grasped by the rows the gripper holds, else a body or joint of that name."""
    from simhost.worlds.track2 import FAMILIES, BenchEnv, ScriptedExpert, task_truth

    order: dict[str, tuple[str, ...]] = {}
    out: dict[str, dict[str, set[str]]] = {}
    for family in FAMILIES:
        found = out.setdefault(family, {})
        for params in variants(family):
            env = BenchEnv(params, split="dev")
            try:
                env.reset(seed=0)
                task, model = env.task, env.model
                order[family] = tuple(task.part_names)
                rows = {ref[1]: n for n, ref in zip(task.part_names, task.row_refs(),
                                                    strict=True)
                        if ref is not None and ref[0] == "body"}

                names = {v.part for v in task_truth(params, env.config).state_variables
                         if v.part is not None}
                held: dict[str, set[str]] = {}
                expert = ScriptedExpert(env)
                for _ in range(env.max_steps):
                    for key, on in task.evaluate().flags.items():
                        event, name = key.split(":", 1)
                        names.add(name)
                        if on and event == "grasped":
                            held.setdefault(name, set()).update(
                                r for b, r in rows.items() if env.sim.grasping(b))
                    _, _, over, cut, _ = env.step(expert())
                    if over or cut:
                        break
                for name in names:
                    body: int | None = task.loose_parts().get(name)
                    for kind in ("body", "joint"):
                        if body is None:
                            try:
                                item = getattr(model, kind)(name)
                            except KeyError:
                                continue
                            body = int(item.id if kind == "body" else item.bodyid[0])
                    got = ({_row(model, rows, body)} if body is not None
                           else held.get(name, set()))
                    found.setdefault(name, set()).update(r for r in got if r is not None)
            finally:
                env.close()
    return order, out


def _row(model: Any, rows: dict[int, str], body: int) -> str | None:
    """The row of ``body`` or of the nearest body it hangs from."""
    while body > 0 and body not in rows:
        body = int(model.body_parentid[body])
    return rows.get(body)


def part_rows_lines() -> list[str]:
    """The table of ``part_rows``, with each family's row order."""
    order, found = part_rows()
    rows = ["| family | `parts` rows, in order | part names → row |", "|---|---|---|"]
    for family, names in found.items():
        pairs = ", ".join(f"`{n}` → " + (
            "the other tool's row" if n == "wrong_tool" else
            " or ".join(f"`{r}`" for r in sorted(rs))) for n, rs in sorted(names.items()) if rs)
        rows.append(f"| `{family}` | " + ", ".join(f"`{r}`" for r in order[family])
                    + f" | {pairs} |")
    return [
        "Part names: the demonstration's annotations (`events[].part` of `manifest.json`) "
        "and `task_model.json` (`StateVariable.part`, the variables' and predicates' "
        "names) name a task's parts in the task's words (`drawer`, `tool`, `button`); the "
        "observation's `parts` tensor and the packet's `obs_parts` have one row per part "
        "in the family's order (the `rows` of `observation_spec.parts` in the manifest). "
        "Which row each name is (found by playing the scripted expert on every kind of "
        "instance). `tool_use`: `tool` is the useful tool, in the slot its constraint "
        "`tool_slot` names (0: rows `tool_a`, `tool_a_tip`; 1: `tool_b`, `tool_b_tip`), "
        "and `wrong_tool` the distractor in the other slot:",
        "",
        *rows,
        "",
    ]


def constraint_lines() -> list[str]:
    """Each family's constraints: the JSON type of its value, its unit (``UNITS``) and
    the values it takes over every variant."""
    from simhost.worlds.track2 import FAMILIES, split_config, task_truth

    config = split_config("standard").bench
    rows = ["| family | constraint | value | unit | values seen |", "|---|---|---|---|---|"]
    for family in FAMILIES:
        seen: dict[str, list[Any]] = {}
        for params in variants(family):
            for c in task_truth(params, config).constraints:
                if c.value not in seen.setdefault(c.name, []):
                    seen[c.name].append(c.value)
        for name, values in seen.items():
            kind = _json_type(values[0])
            unit = UNITS.get(name, "") if kind not in ("string", "boolean") else ""
            shown = ", ".join(f"`{json.dumps(v)}`" for v in values[:4])
            rows.append(f"| `{family}` | `{name}` | {kind} | {unit or '—'} | {shown} |")
    return [
        "Constraint values (`task_model.json`'s `constraints[].value`): their JSON type "
        "and unit, and the values they take over every kind of instance of the official "
        "splits' source (an instance's numbers vary around these):",
        "",
        *rows,
        "",
    ]


def _json_type(value: Any) -> str:
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "number"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list | tuple):
        inner = {_json_type(v) for v in value}
        return "list of " + ("numbers" if inner <= {"integer", "number"} else
                             " or ".join(sorted(inner)) + "s")
    return "object"


def vocabulary(plugin: TrackPlugin[Track2Scenario, Any]) -> str:
    """The Markdown that ends Track 2's section of the protocol page."""
    from simhost.worlds.track2 import FAMILIES, split_config, task_truth

    split = next(iter(plugin.splits))
    config = split_config(split).bench
    truths: list[tuple[str, Any]] = []
    for family in sorted(FAMILIES):
        shapes: list[tuple[Any, ...]] = []
        for label, params in labelled_variants(family):
            t = task_truth(params, config)
            shape = (t.stages, [v.name for v in t.state_variables],
                     [c.name for c in t.constraints], t.preconditions,
                     [(c.variable, c.op) for c in t.success])
            if shape not in shapes:  # one row per kind of instance whose names differ
                shapes.append(shape)
                truths.append((f"`{family}`" + (f" ({label})" if label else ""), t))
    rows = ["| family | stages | variables | constraints | preconditions | success |",
            "|---|---|---|---|---|---|"]
    for family, t in truths:
        pre = "; ".join(f"`{k}`: " + ", ".join(f"`{r}`" for r in v)
                        for k, v in t.preconditions.items())
        rows.append(
            f"| {family} | " + " ".join(f"`{x}`" for x in t.stages) + " | "
            + ", ".join(f"`{v.name}`" for v in t.state_variables) + " | "
            + ", ".join(f"`{c.name}`" for c in t.constraints) + f" | {pre or '—'} | "
            + ", ".join(f"`{c.variable} {c.op}`" for c in t.success) + " |")
    examples = [(0.0105, 0.01), (0.011, 0.01), (0.012, 0.01), (1.1, 1.0), ([1.0, 2.2],
                [1.0, 2.0]), (True, True), ("Peg", "peg")]
    cases = "; ".join(f"`{json.dumps(p)}` for `{json.dumps(t)}`: {_scoring.close(p, t):.2f}"
                      for p, t in examples)
    rule = next(" ".join(b.split()) for b in (_scoring.__doc__ or "").split("\n- ")
                if b.startswith("``task_model``"))
    weights = ", ".join(f"{k} {w:g}" for k, w in _scoring.MODEL_WEIGHTS.items())
    return "\n".join([
        *packet_keys(plugin, split),
        *part_rows_lines(),
        "Task-model names per family (`simhost.worlds.track2.task_truth` of each kind of "
        "instance; a family has one row per kind whose names differ, labelled by the "
        "parameter that makes it): a model of another family scores 0.",
        "",
        *rows,
        "",
        *constraint_lines(),
        "How a model is compared with the truth (`plugins.track2._scoring`, weights "
        f"`MODEL_WEIGHTS`: {weights}): {rule.removeprefix('``task_model``: ')}",
        "",
        "Values (constraints, success criteria) are compared by "
        "`plugins.track2._scoring.close`, credit in [0, 1]; for example " + cases + ".",
    ])


def packet_keys(plugin: TrackPlugin[Track2Scenario, Any], split: str) -> list[str]:
    """The arrays of the demonstration packet's ``trajectory.npz`` (written for sampled
    instances of every family; T is the number of actions)."""
    shapes: dict[str, dict[str, str]] = {}
    for i in range(SAMPLES):
        scenario = plugin.make_scenario(seed=i, split=split, params={"demo_frames": False},
                                        index=i)
        family = Track2Scenario.of(scenario).family
        with tempfile.TemporaryDirectory(prefix="eagc-doc-") as tmp:
            plugin.write_inputs(scenario, Path(tmp))
            with np.load(next(Path(tmp).rglob("trajectory.npz"))) as z:
                steps = len(z["actions"]) if "actions" in z.files else -1
                for key in z.files:
                    a = z[key]
                    lead = {steps: "T", steps + 1: "T+1"}.get(a.shape[0], str(a.shape[0])) \
                        if a.shape else ""
                    dims = " × ".join([lead, *map(str, a.shape[1:])]) if a.shape else "scalar"
                    shapes.setdefault(key, {})[family] = f"{a.dtype} {dims}"
    rows = ["| array | dtype and shape |", "|---|---|"]
    for key, by in shapes.items():
        kinds = set(by.values())
        cell = next(iter(kinds)) if len(kinds) == 1 else "; ".join(
            f"{f}: {v}" for f, v in sorted(by.items()))
        rows.append(f"| `{key}` | {cell} |")
    return ["The demonstration packet's `trajectory.npz` (`$EAGC_INPUT/demo`, beside "
            "`manifest.json`, [`DemoManifest`](json/demo_manifest.json)); T is the number "
            "of actions:", "", *rows, ""]
