"""``task_model.json`` from the demonstration and the hidden instance's first observation.

The vocabulary is the bench's (``simhost/track2/_truth.py``). What the observation shows is
read from it (goal vector, part poses, which parts are present, the opening mechanism, the
longer tool); what it cannot show (peg shape, clearance, well depth, …) is the
demonstration's source value; a measured value (an opening's range) replaces it later.
"""

from __future__ import annotations

import math
from typing import Any

from controllers import SCALES, View, opening_kind, pick_tool

WMAX = 0.09
PART = {"drawer": "drawer", "sliding_cover": "cover", "swivel_lid": "lid"}


def _v(name: str, kind: str, part: str | None = None) -> dict[str, Any]:
    return {"name": name, "type": kind, **({"part": part} if part else {})}


def _c(variable: str, op: str, value: Any) -> dict[str, Any]:
    return {"variable": variable, "op": op, "value": value}


def _insertion(v: View, src: dict[str, Any], hints: dict[str, Any]) -> dict[str, Any]:
    shape = src["geometry"]["shape"]
    clearance = float(src["geometry"]["clearance"])
    need, depth = float(v.goal()[1]), float(v.goal()[2])
    period = {"square": math.pi / 2, "rect": math.pi, "round": 2 * math.pi}[shape]
    return {
        "stages": ["reach", "grasp", "transport", "align", "insert", "release"],
        "variables": [_v("ee_pose", "pose"), _v("gripper_width", "length"),
                      _v("peg_pose", "pose", "peg"), _v("hole_pose", "pose", "hole"),
                      _v("peg_grasped", "bool", "peg"), _v("peg_lifted", "bool", "peg"),
                      _v("peg_hole_offset", "length", "peg"), _v("peg_yaw_error", "angle", "peg"),
                      _v("insertion_depth", "length", "peg")],
        "constraints": {"peg_shape": shape, "clearance": clearance, "yaw_symmetry": period,
                        "hole_depth": depth, "peg_upright": True, "max_grip_width": WMAX},
        "preconditions": {"grasp": ["gripper_open", "gripper_at_peg"],
                          "transport": ["peg_grasped"], "align": ["peg_grasped", "peg_lifted"],
                          "insert": ["peg_grasped", "peg_aligned"], "release": ["peg_inserted"]},
        "success": [_c("insertion_depth", ">=", need),
                    _c("peg_hole_offset", "<=", clearance / 2 + 0.002),
                    _c("peg_grasped", "==", False)],
    }


def _rotation(v: View, src: dict[str, Any], hints: dict[str, Any]) -> dict[str, Any]:
    kind = src["geometry"]["kind"]
    goal, tol, sign = (float(x) for x in v.goal()[1:4])
    return {
        "stages": ["reach", "grasp", "turn", "release"],
        "variables": [_v("ee_pose", "pose"), _v("gripper_width", "length"),
                      _v("knob_angle", "angle", "knob"), _v("knob_grasped", "bool", "knob"),
                      _v("angle_error", "angle", "knob")],
        "constraints": {"handle_kind": kind, "rotation_axis": "vertical",
                        "grasp_symmetry": math.pi / 3 if kind == "nut" else math.pi,
                        "turn_direction": "ccw" if sign > 0 else "cw",
                        "turn_angle": abs(goal - hints["initial_joint"]),
                        "angle_tolerance": tol, "max_grip_width": WMAX},
        "preconditions": {"grasp": ["gripper_open", "gripper_at_knob"], "turn": ["knob_grasped"],
                          "release": ["knob_at_goal"]},
        "success": [_c("knob_angle", "within", [goal - tol, goal + tol]),
                    _c("knob_grasped", "==", False)],
    }


def _assembly(v: View, src: dict[str, Any], hints: dict[str, Any]) -> dict[str, Any]:
    n = sum(v.present(i) for i in (1, 2, 3))
    names = [f"part{i + 1}" for i in range(n)]
    half = float(src["geometry"]["part_half"])
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
    return {
        "stages": stages, "variables": variables, "preconditions": pre, "success": success,
        "constraints": {"n_parts": n, "order": ["tray", *names],
                        "part_half_widths": [half * k for k in SCALES[:n]],
                        "part_height": 2 * (float(v.pos(1)[2]) - 0.0005),
                        "tray_clearance": float(src["geometry"]["tray_clearance"]),
                        "xy_tolerance": 0.008, "yaw_tolerance": 0.1,
                        "yaw_symmetry": math.pi / 2, "max_grip_width": WMAX},
    }


def _opening(v: View, src: dict[str, Any], hints: dict[str, Any]) -> dict[str, Any]:
    kind = opening_kind(v)
    part = PART[kind]
    goal, tol, sign = (float(x) for x in v.goal()[1:4])
    verb = "open" if sign > 0 else "close"
    geo = src["geometry"]
    guess = float(geo["swing"] if kind == "swivel_lid" else geo["travel"])
    return {
        "stages": ["reach", "grasp", verb, "release"],
        "variables": [_v("ee_pose", "pose"), _v("gripper_width", "length"),
                      _v(f"{part}_pose", "pose", part), _v(f"{part}_opening", "fraction", part),
                      _v(f"{part}_grasped", "bool", part)],
        "constraints": {"mechanism": kind,
                        "joint_type": "revolute" if kind == "swivel_lid" else "prismatic",
                        "joint_range": float(hints.get("range_measured", guess)),
                        "direction": verb, "opening_tolerance": tol, "max_grip_width": WMAX},
        "preconditions": {"grasp": ["gripper_open", f"gripper_at_{part}_handle"],
                          verb: [f"{part}_grasped"], "release": [f"{part}_at_goal"]},
        "success": [_c(f"{part}_opening", "within", [max(0.0, goal - tol), min(1.0, goal + tol)]),
                    _c(f"{part}_grasped", "==", False)],
    }


def _tool_use(v: View, src: dict[str, Any], hints: dict[str, Any]) -> dict[str, Any]:
    press = v.goal()[0] < 0.5
    use = "press" if press else "pull"
    slot, length = pick_tool(v)
    variables = [_v("ee_pose", "pose"), _v("gripper_width", "length"),
                 _v("tool_pose", "pose", "tool"), _v("tool_tip_position", "position", "tool"),
                 _v("tool_grasped", "bool", "tool")]
    constraints: dict[str, Any] = {
        "mechanism": use, "tool_slot": slot, "tool_length": length,
        "distractor_present": v.present(2 * (1 - slot)), "target_out_of_gripper_reach": True,
        "max_grip_width": WMAX}
    if press:
        variables += [_v("button_travel", "length", "button"), _v("tip_in_well", "bool", "tool")]
        constraints |= {"well_depth": float(src["geometry"]["well_depth"]), "well_width": 0.022,
                        "press_depth": 0.006}
        success = [_c("button_travel", ">=", 0.006)]
        pre = ["tool_grasped", "tip_over_well"]
    else:
        goal_x, tol = float(v.goal()[1]), float(v.goal()[2])
        variables += [_v("puck_position", "position", "puck"), _v("puck_x", "length", "puck"),
                      _v("tip_behind_puck", "bool", "tool")]
        constraints |= {"goal_x": goal_x, "goal_tolerance": tol}
        success = [_c("puck_x", "within", [goal_x - tol, goal_x + tol])]
        pre = ["tool_grasped", "tip_behind_puck"]
    return {
        "stages": ["reach_tool", "grasp_tool", "carry_tool", use], "variables": variables,
        "constraints": constraints, "success": success,
        "preconditions": {"grasp_tool": ["gripper_open", "gripper_at_tool"],
                          "carry_tool": ["tool_grasped"], use: pre},
    }


BUILDERS = {"insertion": _insertion, "rotation": _rotation, "assembly": _assembly,
            "opening": _opening, "tool_use": _tool_use}


def task_model(family: str, view: View, source: dict[str, Any], hints: dict[str, Any],
               step: int) -> dict[str, Any]:
    """The ``task_model.json`` document (schema ``eagc-task-model/v1``)."""
    m = BUILDERS[family](view, source, hints)
    return {
        "version": "eagc-task-model/v1",
        "step": step,
        "family": family,
        "stages": m["stages"],
        "variables": m["variables"],
        "constraints": [{"name": k, "value": round(v, 6) if isinstance(v, float) else v}
                        for k, v in m["constraints"].items()],
        "preconditions": [{"stage": k, "requires": r} for k, r in m["preconditions"].items()],
        "success_criteria": [{**c, "value": [round(x, 6) for x in c["value"]]
                              if isinstance(c["value"], list) else c["value"]}
                             for c in m["success"]],
    }
