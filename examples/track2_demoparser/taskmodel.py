"""``task_model.json`` from the demonstration, the hidden instance's observations and what an
agent measured while acting.

The vocabulary is the bench's public one (the track README): stage, variable, predicate and
constraint names per family. Values come from the packet (the goal annotation's magnitude,
the turning direction, the last key stage), from the instance's observation (parts present,
heights, which tool is longer) and from the agent's own measurements (``measured``: an
opening's range, a blocked direction, ...). Constraints nobody observed are left out rather
than guessed: a wrong value costs as much as a missing one.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from controllers import View

from schemas import TaskModel

WMAX = 0.09
PART = {"drawer": "drawer", "sliding_cover": "cover", "swivel_lid": "lid"}
# The official splits' tolerances (the dev split's when the observation states a goal).
TOL = {"rotation": (0.05, 0.08), "opening": (0.05, 0.08), "xy": (0.005, 0.008),
       "yaw": (0.08, 0.1), "pull": (0.012, 0.02)}


def _v(name: str, kind: str, part: str | None = None) -> dict[str, Any]:
    return {"name": name, "type": kind, **({"part": part} if part else {})}


def _c(variable: str, op: str, value: Any) -> dict[str, Any]:
    return {"variable": variable, "op": op, "value": value}


def _tol(key: str, dev: bool) -> float:
    return TOL[key][1 if dev else 0]


def _insertion(v: View, h: dict[str, Any], m: dict[str, Any], dev: bool) -> dict[str, Any]:
    cons: dict[str, Any] = {"peg_upright": True, "max_grip_width": WMAX}
    success = [_c("peg_grasped", "==", False)]
    if "depth" in h:
        cons["hole_depth"] = h["depth"]
        success.insert(0, _c("insertion_depth", ">=", 0.7 * h["depth"]))
    if "symmetry" in m:
        cons["yaw_symmetry"] = m["symmetry"]
    return {
        "stages": ["reach", "grasp", "transport", "align", "insert", "release"],
        "variables": [_v("ee_pose", "pose"), _v("gripper_width", "length"),
                      _v("peg_pose", "pose", "peg"), _v("hole_pose", "pose", "hole"),
                      _v("peg_grasped", "bool", "peg"), _v("peg_lifted", "bool", "peg"),
                      _v("peg_hole_offset", "length", "peg"), _v("peg_yaw_error", "angle", "peg"),
                      _v("insertion_depth", "length", "peg")],
        "constraints": cons,
        "preconditions": {"grasp": ["gripper_open", "gripper_at_peg"],
                          "transport": ["peg_grasped"], "align": ["peg_grasped", "peg_lifted"],
                          "insert": ["peg_grasped", "peg_aligned"], "release": ["peg_inserted"]},
        "success": success,
    }


def _rotation(v: View, h: dict[str, Any], m: dict[str, Any], dev: bool) -> dict[str, Any]:
    turn = float(m.get("turn", h.get("turn", 1.0)))
    tol = _tol("rotation", dev)
    cons: dict[str, Any] = {"rotation_axis": "vertical", "turn_direction":
                            "ccw" if turn > 0 else "cw", "turn_angle": abs(turn),
                            "angle_tolerance": tol, "max_grip_width": WMAX}
    if "symmetry" in m:
        cons["grasp_symmetry"] = m["symmetry"]
    return {
        "stages": ["reach", "grasp", "turn", "release"],
        "variables": [_v("ee_pose", "pose"), _v("gripper_width", "length"),
                      _v("knob_angle", "angle", "knob"), _v("knob_turn", "angle", "knob"),
                      _v("knob_grasped", "bool", "knob")],
        "constraints": cons,
        "preconditions": {"grasp": ["gripper_open", "gripper_at_knob"], "turn": ["knob_grasped"],
                          "release": ["knob_at_goal"]},
        "success": [_c("knob_turn", "within", [turn - tol, turn + tol]),
                    _c("knob_grasped", "==", False)],
    }


def _assembly(v: View, h: dict[str, Any], m: dict[str, Any], dev: bool) -> dict[str, Any]:
    n = sum(v.present(i) for i in (1, 2, 3))
    names = [f"part{i + 1}" for i in range(n)]
    variables = [_v("ee_pose", "pose"), _v("gripper_width", "length"),
                 _v("tray_pose", "pose", "tray")]
    stages, pre, success = [], {}, []
    for i, name in enumerate(names):
        below = "tray" if i == 0 else names[i - 1]
        stages += [f"{s}_{name}" for s in ("reach", "grasp", "transport", "place")]
        variables += [_v(f"{name}_pose", "pose", name), _v(f"{name}_grasped", "bool", name),
                      _v(f"{name}_offset", "length", name),
                      _v(f"{name}_yaw_error", "angle", name), _v(f"{name}_placed", "bool", name)]
        pre[f"grasp_{name}"] = ["gripper_open", f"gripper_at_{name}"]
        pre[f"transport_{name}"] = [f"{name}_grasped"]
        pre[f"place_{name}"] = [f"{name}_grasped", f"{name}_over_{below}"] + (
            [f"{below}_placed"] if i else [])
        success.append(_c(f"{name}_placed", "==", True))
    cons = {"n_parts": n, "order": ["tray", *names],
            "part_height": round(2 * float(v.pos(1)[2]), 4),
            "xy_tolerance": _tol("xy", dev), "yaw_tolerance": _tol("yaw", dev),
            "yaw_symmetry": math.pi / 2, "max_grip_width": WMAX}
    return {"stages": stages, "variables": variables, "preconditions": pre, "success": success,
            "constraints": cons}


def _opening(v: View, h: dict[str, Any], m: dict[str, Any], dev: bool) -> dict[str, Any]:
    kind = str(h.get("kind", "drawer"))
    part = PART[kind]
    verb = h.get("mode", "open")
    goal = float(h.get("fraction", 0.8 if verb == "open" else 0.2))
    tol = _tol("opening", dev)
    cons: dict[str, Any] = {"mechanism": kind,
                            "joint_type": "revolute" if kind == "swivel_lid" else "prismatic",
                            "direction": verb, "opening_tolerance": tol,
                            "max_grip_width": WMAX}
    if "range_measured" in m:
        cons["joint_range"] = m["range_measured"]
    return {
        "stages": ["reach", "grasp", verb, "release"],
        "variables": [_v("ee_pose", "pose"), _v("gripper_width", "length"),
                      _v(f"{part}_pose", "pose", part), _v(f"{part}_opening", "fraction", part),
                      _v(f"{part}_grasped", "bool", part)],
        "constraints": cons,
        "preconditions": {"grasp": ["gripper_open", f"gripper_at_{part}_handle"],
                          verb: [f"{part}_grasped"], "release": [f"{part}_at_goal"]},
        "success": [_c(f"{part}_opening", "within", [max(0.0, goal - tol), min(1.0, goal + tol)]),
                    _c(f"{part}_grasped", "==", False)],
    }


def _tool_use(v: View, h: dict[str, Any], m: dict[str, Any], dev: bool) -> dict[str, Any]:
    use = m.get("mechanism", h.get("mechanism", "press"))
    press = use == "press"
    slot = int(m.get("slot", h.get("slot", 0)))
    # the tool's length: from its grip row to its tip row, as observed on this instance
    length = float(np.linalg.norm(v.pos(2 * slot)[:2] - v.pos(2 * slot + 1)[:2])) \
        if v.present(2 * slot) else 0.0
    variables = [_v("ee_pose", "pose"), _v("gripper_width", "length"),
                 _v("tool_pose", "pose", "tool"), _v("tool_tip_position", "position", "tool"),
                 _v("tool_grasped", "bool", "tool")]
    constraints: dict[str, Any] = {
        "mechanism": use, "tool_slot": slot, "tool_length": round(length, 4),
        "distractor_present": v.present(2 * (1 - slot)), "target_out_of_gripper_reach": True,
        "max_grip_width": WMAX}
    if press:
        variables += [_v("button_travel", "length", "button"), _v("tip_in_well", "bool", "tool")]
        depth = float(h.get("press_depth", 0.0))
        if depth > 0.002:  # what the demonstration pressed it by (the well is not seen)
            constraints |= {"press_depth": depth}
        success = [_c("button_travel", ">=", max(depth, 0.002))]
        pre = ["tool_grasped", "tip_over_well"]
    else:
        tol = _tol("pull", dev)
        variables += [_v("puck_position", "position", "puck"),
                      _v("puck_goal_offset", "length", "puck"),
                      _v("tip_behind_puck", "bool", "tool")]
        constraints |= {"goal_tolerance": tol}
        success = [_c("puck_goal_offset", "within", [-tol, tol])]
        pre = ["tool_grasped", "tip_behind_puck"]
    return {
        "stages": ["reach_tool", "grasp_tool", "carry_tool", use], "variables": variables,
        "constraints": constraints, "success": success,
        "preconditions": {"grasp_tool": ["gripper_open", "gripper_at_tool"],
                          "carry_tool": ["tool_grasped"], use: pre},
    }


BUILDERS = {"insertion": _insertion, "rotation": _rotation, "assembly": _assembly,
            "opening": _opening, "tool_use": _tool_use}


def task_model(family: str, view: View, hints: dict[str, Any], measured: dict[str, Any],
               step: int, *, dev: bool) -> TaskModel:
    """The ``task_model.json`` document (schema ``eagc-task-model/v1``); constraints in
    ``measured["constraints"]`` are added as they are."""
    m = BUILDERS[family](view, hints, measured, dev)
    m["constraints"] = {**m["constraints"], **measured.get("constraints", {})}

    def rnd(x: Any) -> Any:
        if isinstance(x, float):
            return round(x, 6)
        if isinstance(x, list):
            return [rnd(y) for y in x]
        return x

    return TaskModel.model_validate({
        "step": step,
        "family": family,
        "stages": m["stages"],
        "variables": m["variables"],
        "constraints": [{"name": k, "value": rnd(v)} for k, v in m["constraints"].items()],
        "preconditions": [{"stage": k, "requires": r} for k, r in m["preconditions"].items()],
        "success_criteria": [{**c, "value": rnd(c["value"])} for c in m["success"]],
    })
