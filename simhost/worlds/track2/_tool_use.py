"""Two-step tool use: fetch the right tool, then press a sunken button or pull a far puck.

Tools stand in two slots at ``x = -0.14, y = +/-0.10``; ``tool_slot`` holds the useful tool,
the other slot a too-short distractor when ``distractor`` is set.

- ``press``: a stick (shaft of ``tool_length`` with a square handle on top) stands in a rack;
  a button sits at the bottom of a narrow well ``well_depth`` deep, too narrow for the
  fingers. Success: the button pushed down by ``PRESS_DEPTH``. The short stick cannot reach.
- ``pull``: a hoe (tall handle, shaft of ``tool_length + 0.1``, blade) lies on the table; a
  puck lies beyond the hand's reach (x > 0.3). Success: the puck's centre within
  ``tolerances.pull_m`` of the goal line (a strip of green tape 1 cm wide, visual only, its
  centre the line). The short hoe cannot reach
  behind the puck.

On the wide ranges the mechanism itself may differ from the demonstration's
(``VariationConfig.mechanism_switch``).

Parts rows: ``tool_a``, ``tool_a_tip``, ``tool_b``, ``tool_b_tip`` (handle pose and tip
position of the tool in slot 0 / 1, zero when the slot is empty), ``target`` (button, joint =
its travel; or puck) and ``fixture`` (the well; or the goal-line marker).
Stages: ``reach_tool -> grasp_tool -> carry_tool -> press|pull``.
Events: ``grasped``/``released`` (``tool``, or ``wrong_tool`` for the distractor), ``lifted``
(``tool``), ``pressed`` (``button``) or ``aligned`` (``puck``).
Goal vector (dev): press ``[0, 0, 0, 0]`` (no goal stated); pull ``[1, goal_x, tolerance, 0]``.
``info["value"]``: the button's travel (m) or the puck's x offset from the goal line (m).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ._bench import (
    BUTTON_HALF,
    BUTTON_TOP,
    WELL_IN,
    WELLS_REGION,
    WIDTH_MAX,
    Scene,
    dress,
    hide,
    quat_z,
    wrap,
)
from ._family import (
    Evaluation,
    FamilyTask,
    Plan,
    box_walls,
    crit,
    hold,
    idle,
    move,
    nearest_yaw,
    pick,
    servo,
    truth_doc,
    var,
)
from ._truth import TaskTruth

if TYPE_CHECKING:
    from ._family import Bench
    from ._sim import Sim

SLOTS = ((-0.14, 0.10), (-0.14, -0.10))
SHORT = 0.05  # distractor stick length / hoe reach (m)
HANDLE = (0.01, 0.01, 0.015)  # stick handle half-sizes
HOE_HANDLE_H = 0.03  # hoe handle half-height
SHAFT_Z = 0.03  # hoe shaft height above the table: it passes over the puck
RACK_IN = 0.0065  # rack inner half-width around a 0.005 shaft
RACK_H = 0.045
PRESS_DEPTH = 0.006
PALM_GAP = 0.056  # TCP below a handle's top when the palm rests on it
LINE_HALF = 0.005  # m: half-width of the goal line's green tape (visual; its centre is the goal)


class ToolUseTask(FamilyTask):
    family = "tool_use"
    part_names = ("tool_a", "tool_a_tip", "tool_b", "tool_b_tip", "target", "fixture")
    max_steps = 400

    def __init__(self, params: Any, config: Any = None) -> None:
        super().__init__(params, config)
        p = params
        self.goal_tol = self.tol.pull_m
        self.press = p.value("mechanism") == "press"
        self.slot = int(p.value("tool_slot"))  # type: ignore[arg-type]
        self.square = p.value("tool_shape") == "square"
        useful = p.f("tool_length") + (0.0 if self.press else 0.1)
        self.lengths: list[float | None] = [None, None]
        self.lengths[self.slot] = useful
        if p.value("distractor"):
            self.lengths[1 - self.slot] = SHORT
        u, v = p.f("target_u"), p.f("target_v")
        if self.press:
            (x0, x1), (y0, y1) = WELLS_REGION
            self.target_xy0 = np.array([x0 + (x1 - x0) * u, y0 + (y1 - y0) * v])
        else:
            self.target_xy0 = np.array([0.36 + 0.06 * u, -0.10 + 0.20 * v])
        self.goal_x0 = 0.08 + 0.12 * p.f("goal_u")
        self.depth = p.f("well_depth")
        self.r = p.f("puck_radius")

    # -- building ------------------------------------------------------------------------------
    def _tool(self, slot: int, length: float) -> str:
        p = self.p
        fr = f'friction="{p.f("part"):.4f} 0.005 0.0001"'
        x0, y0 = SLOTS[slot]
        x, y = x0 + p.f("tool_dx"), y0 + p.f("tool_dy")
        colour = 'rgba="0.1 0.6 0.6 1"' if length > SHORT else 'rgba="0.6 0.3 0.6 1"'
        name = "tool_a" if slot == 0 else "tool_b"
        rho = 1.33 * p.f("density")
        if self.press:
            hx, hy, hz = HANDLE
            shaft = (
                f'type="box" size="0.005 0.005 {length / 2:.5f}"'
                if self.square
                else f'type="cylinder" size="0.005 {length / 2:.5f}"'
            )
            return (
                f'<body name="{name}" pos="{x:.5f} {y:.5f} {length + hz + 0.0005:.5f}" '
                f'quat="{quat_z(p.f("tool_yaw"))}"><freejoint name="{name}"/>'
                f'<geom material="wood_light" type="box" size="{hx} {hy} {hz}" '
                f'density="{rho * 0.5:.1f}" {fr} {colour}/>'
                f'<geom material="steel" {shaft} pos="0 0 {-hz - length / 2:.5f}" '
                f'density="{rho:.1f}" {fr} {colour}/>'
                f'<site name="{name}_tip" pos="0 0 {-hz - length:.5f}" size="0.003"/></body>'
                f'<body name="rack_{slot}" pos="{x:.5f} {y:.5f} 0" '
                f'quat="{quat_z(p.f("tool_yaw"))}">'
                + dress(box_walls(RACK_IN, RACK_IN, 0.008, RACK_H), "wood_dark")
                + "</body>"
            )
        yaw = (math.pi / 2 if slot == 0 else -math.pi / 2) + p.f("tool_yaw")
        shaft = (
            f'type="box" size="{length / 2:.5f} 0.004 0.004"'
            if self.square
            else f'type="capsule" size="0.004 {length / 2 - 0.004:.5f}" euler="0 1.5708 0"'
        )
        return (
            f'<body name="{name}" pos="{x:.5f} {y:.5f} {HOE_HANDLE_H + 0.0005:.5f}" '
            f'quat="{quat_z(yaw)}"><freejoint name="{name}"/>'
            f'<geom material="wood_light" type="box" size="0.01 0.01 {HOE_HANDLE_H}" '
            f'density="400" {fr} {colour}/>'
            f'<geom material="steel" {shaft} '
            f'pos="{length / 2:.5f} 0 {SHAFT_Z - HOE_HANDLE_H:.5f}" density="300" {fr} {colour}/>'
            f'<geom material="steel" type="box" size="0.006 0.04 {SHAFT_Z / 2 + 0.002:.5f}" '
            f'pos="{length:.5f} 0 {SHAFT_Z / 2 + 0.002 - HOE_HANDLE_H:.5f}" density="300" {fr} '
            f'{colour}/>'
            f'<site name="{name}_tip" pos="{length:.5f} 0 {-HOE_HANDLE_H:.5f}" size="0.003"/>'
            f"</body>"
        )

    def scene(self) -> Scene:
        p = self.p
        tools = "".join(self._tool(i, n) for i, n in enumerate(self.lengths) if n is not None)
        tx, ty = self.target_xy0
        if self.press:
            walls = dress(box_walls(WELL_IN, WELL_IN, 0.015, self.depth), "wood_dark")
            target = f"""
    <body name="fixture" pos="{tx:.5f} {ty:.5f} 0">{walls}
      <geom class="fixture" material="wood_dark" rgba="1 1 1 1" type="box" pos="0 0 0.003"
        size="{WELL_IN} {WELL_IN} 0.003"/>
    </body>
    <body name="target" pos="{tx:.5f} {ty:.5f} {BUTTON_TOP - 0.005:.5f}">
      <joint name="button" type="slide" axis="0 0 1" range="-0.012 0" stiffness="400"
        damping="2" armature="0.01"/>
      <geom type="box" size="{BUTTON_HALF} {BUTTON_HALF} 0.005" mass="0.01"
        rgba="0.9 0.1 0.1 1"/>
    </body>"""
            contact = '<exclude body1="fixture" body2="target"/>'
        else:
            target = f"""
    <body name="target" pos="{tx:.5f} {ty:.5f} 0.0105"><freejoint name="puck"/>
      <geom material="wood_light" type="cylinder" size="{self.r:.5f} 0.01"
        density="{p.f('density'):.1f}" friction="{p.f('part'):.4f} 0.005 0.0001"
        rgba="0.9 0.5 0.1 1"/>
    </body>
    <body name="fixture" pos="{self.goal_x0:.5f} 0 0.0005">
      {hide('<geom type="box" size="0.003 0.2 0.0005" contype="0" conaffinity="0"/>')}
      <geom class="visual" type="box" size="{LINE_HALF} 0.2 0.0005" rgba="0.1 0.8 0.1 1"/>
    </body>"""
            contact = ""
        return Scene(bodies=tools + target, contact=contact)

    def bind(self, sim: Sim) -> None:
        super().bind(sim)
        names = ("tool_a", "tool_b")
        self.tools = [sim.bid(names[i]) if n is not None else None
                      for i, n in enumerate(self.lengths)]
        self.tips = [
            int(sim.model.site(f"{names[i]}_tip").id) if n is not None else None
            for i, n in enumerate(self.lengths)
        ]
        self.tool = sim.bid(names[self.slot])
        self.tip_site = int(sim.model.site(f"{names[self.slot]}_tip").id)
        self.other = self.tools[1 - self.slot]
        self.target = sim.bid("target")
        self.fixture = sim.bid("fixture")

    def loose_parts(self) -> dict[str, int]:
        out = {"tool": self.tool}
        if self.other is not None:
            out["wrong_tool"] = self.other
        return out

    def jitter_groups(self) -> tuple[tuple[str, ...], ...]:
        names = ("tool_a", "tool_b")
        tools = [(names[i], f"rack_{i}") if self.press else (names[i],)
                 for i, n in enumerate(self.lengths) if n is not None]
        targets = [("fixture", "target")] if self.press else [("target",), ("fixture",)]
        return (*tools, *targets)

    def row_refs(self) -> tuple[tuple[str, int] | None, ...]:
        rows: list[tuple[str, int] | None] = []
        for b, t in zip(self.tools, self.tips, strict=True):
            rows += [None, None] if b is None or t is None else [("body", b), ("site", t)]
        return (*rows, ("body", self.target), ("body", self.fixture))

    def row_links(self) -> dict[int, int]:
        return {1: 0, 3: 2}

    def symmetry(self) -> tuple[float, ...]:
        tool = math.pi / 2 if self.press else 2 * math.pi
        target = math.pi / 2 if self.press else 2 * math.pi
        return (tool, 2 * math.pi, tool, 2 * math.pi, target, 2 * math.pi)

    def yaw_priors(self) -> dict[int, float]:
        base = self.p.f("tool_yaw")
        if self.press:
            return {0: base, 2: base}
        return {0: math.pi / 2 + base, 2: -math.pi / 2 + base}

    @property
    def target_xy(self) -> np.ndarray:
        """Where the button or the puck started (the jittered fixture)."""
        return self.s.model.body_pos[self.target][:2].copy() if self.press else \
            self._puck0[:2].copy()

    @property
    def goal_x(self) -> float:
        return float(self.s.pos(self.fixture)[0])

    def reset(self, sim: Sim, jitter: float) -> None:
        self._puck0 = np.array(self.target_xy0)
        if not self.press:  # the puck's jittered start
            adr = int(sim.model.jnt_qposadr[sim.model.body_jntadr[self.target]])
            self._puck0 = sim.data.qpos[adr : adr + 2].copy()
    def stages(self) -> tuple[str, ...]:
        return ("reach_tool", "grasp_tool", "carry_tool", "press" if self.press else "pull")

    def parts(self) -> np.ndarray:
        rows = []
        for b, t in zip(self.tools, self.tips, strict=True):
            if b is None or t is None:
                rows += [np.zeros(9), np.zeros(9)]
            else:
                rows += [self.row(b), np.array([1.0, *self.s.data.site_xpos[t], *self.s.quat(b),
                                                0.0])]
        joint = self.s.qpos("button") if self.press else 0.0
        rows += [self.row(self.target, joint), self.row(self.fixture)]
        return self.pad(rows)

    def goal(self) -> np.ndarray:
        if self.press:
            return np.zeros(4)
        return np.array([1.0, self.goal_x, self.goal_tol, 0.0])

    # -- reading -------------------------------------------------------------------------------
    def tip(self) -> np.ndarray:
        return self.s.data.site_xpos[self.tip_site].copy()

    def handle_top(self, body: int) -> np.ndarray:
        hz = HANDLE[2] if self.press else HOE_HANDLE_H
        return self.s.point(body, (0.0, 0.0, hz))

    def done(self) -> bool:
        if self.press:
            return self.s.qpos("button") <= -PRESS_DEPTH
        return abs(float(self.s.pos(self.target)[0]) - self.goal_x) < self.goal_tol

    def value(self) -> float:
        if self.press:
            return -self.s.qpos("button")
        return float(self.s.pos(self.target)[0]) - self.goal_x

    def evaluate(self) -> Evaluation:
        s = self.s
        held = s.grasping(self.tool)
        tip = self.tip()
        flags = {"grasped:tool": held, "lifted:tool": held and self._lifted()}
        if self.other is not None:
            flags["grasped:wrong_tool"] = s.grasping(self.other)
        success = self.done()
        flags["pressed:button" if self.press else "aligned:puck"] = success
        use = self.stages()[-1]
        value = self.value()
        if success:
            return Evaluation(use, 1.0, True, flags, value)
        if held:
            if self.press:
                near = np.linalg.norm(tip[:2] - self.target_xy) < WELL_IN
                if near and tip[2] < self.depth + 0.01:
                    return Evaluation(use, 1.0 - (tip[2] - BUTTON_TOP) / self.depth, False, flags,
                                      value)
                d = float(np.linalg.norm(tip[:2] - self.target_xy))
            else:
                puck = s.pos(self.target)
                behind = tip[0] > puck[0] and abs(tip[1] - puck[1]) < 0.04 and tip[2] < 0.015
                if behind:
                    span = max(abs(self.target_xy[0] - self.goal_x), 1e-6)
                    return Evaluation(use, 1.0 - abs(puck[0] - self.goal_x) / span, False, flags,
                                      value)
                d = float(np.linalg.norm(tip[:2] - (puck[:2] + [self.r + 0.02, 0.0])))
            return Evaluation("carry_tool", 1.0 - d / 0.4, False, flags, value)
        ee, top = s.ee(), self.handle_top(self.tool)
        if np.linalg.norm(ee[:2] - top[:2]) < 0.012 and ee[2] < top[2]:
            return Evaluation("grasp_tool", 0.0, False, flags, value)
        return Evaluation("reach_tool", 1.0 - float(np.linalg.norm(ee[:3] - top)) / 0.4, False,
                          flags, value)

    def _lifted(self) -> bool:
        z0 = self.lengths[self.slot] + HANDLE[2] if self.press else HOE_HANDLE_H  # type: ignore
        return float(self.s.pos(self.tool)[2]) > z0 + 0.01

    def truth(self) -> TaskTruth:
        use = self.stages()[-1]
        variables = [
            var("ee_pose", "pose"),
            var("gripper_width", "length"),
            var("tool_pose", "pose", "tool"),
            var("tool_tip_position", "position", "tool"),
            var("tool_grasped", "bool", "tool"),
        ]
        constraints: dict[str, Any] = {
            "mechanism": "press" if self.press else "pull",
            "tool_slot": self.slot,
            "tool_length": round(float(self.lengths[self.slot] or 0.0), 6),
            "distractor_present": self.lengths[1 - self.slot] is not None,
            "target_out_of_gripper_reach": True,
            "max_grip_width": WIDTH_MAX,
        }
        if self.press:
            variables += [var("button_travel", "length", "button"),
                          var("tip_in_well", "bool", "tool")]
            constraints |= {"well_depth": round(self.depth, 6), "well_width": 2 * WELL_IN,
                            "press_depth": PRESS_DEPTH}
            pre = ["tool_grasped", "tip_over_well"]
            success = [crit("button_travel", ">=", PRESS_DEPTH)]
        else:
            variables += [var("puck_position", "position", "puck"),
                          var("puck_goal_offset", "length", "puck"),
                          var("tip_behind_puck", "bool", "tool")]
            constraints |= {"goal_tolerance": self.goal_tol}
            pre = ["tool_grasped", "tip_behind_puck"]
            success = [crit("puck_goal_offset", "within",
                            [round(-self.goal_tol, 6), round(self.goal_tol, 6)])]
        return truth_doc(
            self,
            variables,
            constraints,
            {
                "grasp_tool": ["gripper_open", "gripper_at_tool"],
                "carry_tool": ["tool_grasped"],
                use: pre,
            },
            success,
            {"mechanism": "press" if self.press else "pull"},
        )

    # -- expert --------------------------------------------------------------------------------
    def plan(self, env: Bench) -> Plan:
        e = self.e
        top = e.point(self.tool, (0.0, 0.0, HANDLE[2] if self.press else HOE_HANDLE_H))
        tool_yaw = e.yaw(self.tool)
        if self.press:
            yaw0 = nearest_yaw(tool_yaw, math.pi / 2)
            depth = PALM_GAP - 0.002
            lift = top[2] - depth + RACK_H + 0.03  # the tip clears the rack
        else:
            turn = wrap(0.0 - tool_yaw)  # point the shaft along +x
            yaw0 = nearest_yaw(tool_yaw, math.pi, -turn / 2)
            depth, lift = min(PALM_GAP - 0.002, top[2] - 0.004), 0.08
        yield from pick(env, top, yaw0, 0.045, depth, lift)
        yield from (self._press(env) if self.press else self._pull(env, yaw0 + turn))
        yield from idle(env, 0.0)

    def _press(self, env: Bench) -> Plan:
        e = self.e
        target_xy = e.pos(self.target)[:2]
        z = self.depth + 0.02 + (env.sim.ee()[2] - e.site(self.tip_site)[2])
        for _ in range(3):
            ee = env.sim.ee()
            goal = ee[:2] + target_xy - e.site(self.tip_site)[:2]
            yield from move(env, np.array([*goal, z]), ee[3], 0.0, tol=0.003)
        yield from hold(env, 4, 0.0)  # let the estimates settle while still

        def error() -> tuple[np.ndarray, float]:
            return target_xy - e.site(self.tip_site)[:2], 0.0

        yield from servo(env, error, z, tol=0.0015)
        deep = BUTTON_TOP - PRESS_DEPTH - 0.003  # the tip this low has pressed far enough
        for _ in range(80):
            tip = e.site(self.tip_site)
            if tip[2] <= deep:
                break
            ee = env.sim.ee()
            xy = ee[:2] + target_xy - tip[:2]
            step = 0.006 if tip[2] > self.depth else 0.003
            yield from move(env, np.array([*xy, ee[2] - step]), ee[3], 0.0, max_steps=1)
        yield from hold(env, 5, 0.0)

    def _pull(self, env: Bench, yaw: float) -> Plan:
        e = self.e
        ee = env.sim.ee()
        yield from move(env, np.array([*ee[:2], 0.08]), yaw, 0.0, tol=0.004, speed=0.7)
        yield from hold(env, 4, 0.0)
        puck = e.pos(self.target)
        goal_x = float(e.pos(self.fixture)[0])
        for _ in range(3):  # blade beyond the puck, high enough to pass over it
            ee, tip = env.sim.ee(), e.site(self.tip_site)
            want = np.array([puck[0] + self.r + 0.02, puck[1]])
            goal = ee[:2] + want - tip[:2]
            yield from move(env, np.array([*goal, ee[2] - (tip[2] - 0.04)]), yaw, 0.0, tol=0.003)
        ee, tip = env.sim.ee(), e.site(self.tip_site)
        yield from move(env, np.array([*ee[:2], ee[2] - (tip[2] - 0.003)]), yaw, 0.0, speed=0.5,
                        tol=0.002)
        for _ in range(150):
            puck = e.pos(self.target)
            if puck[0] - goal_x < 0.004:
                break
            ee, tip = env.sim.ee(), e.site(self.tip_site)
            dy = puck[1] - tip[1]
            speed = 0.008 if puck[0] - goal_x > 0.03 else 0.003
            z = max(0.012, ee[2] - (tip[2] - 0.003))  # never press the handle into the table
            goal = np.array([ee[0] - speed, ee[1] + 0.5 * dy, z])
            yield from move(env, goal, yaw, 0.0, max_steps=1)
        yield from hold(env, 5, 0.0)
