"""Rotation: grasp a knob, valve handle or nut on a vertical hinge and turn it to a goal angle.

Parts: ``knob`` (hinged about z; its row's ``joint`` is the angle), ``base`` (fixed post).
Shapes: ``knob`` a short thick bar, ``valve`` a long thin bar over a hub, ``nut`` a hexagonal
prism on a bolt. A bar is grasped across its long sides (symmetry pi), the nut across flats
(symmetry pi/3). The hinge has damping and dry friction, so the handle stays where it is left.

Stages: ``reach -> grasp -> turn -> release``.
Success: the angle is within ``TOLERANCE`` of ``init_angle +/- turn`` and the gripper no
longer touches the handle. Events: ``grasped``/``released``, ``turned`` (part ``knob``).
Goal vector: ``[1, goal angle (rad), tolerance (rad), +1 ccw / -1 cw]``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ._bench import WIDTH_MAX, Scene
from ._family import (
    Evaluation,
    FamilyTask,
    Plan,
    crit,
    grip,
    hold,
    idle,
    move,
    nearest_yaw,
    truth_doc,
    var,
)

if TYPE_CHECKING:
    from ._env import BenchEnv
    from ._sim import Sim

TOLERANCE = 0.08


class RotationTask(FamilyTask):
    family = "rotation"
    part_names = ("knob", "base")
    max_steps = 250

    def __init__(self, params: Any) -> None:
        super().__init__(params)
        p = params
        self.kind = str(p.value("kind"))
        k = p.f("size")
        if self.kind == "knob":
            self.half = (0.028 * k, 0.011 * k, 0.012)
        elif self.kind == "valve":
            self.half = (0.05 * k, 0.0065 * k, 0.008)
        else:  # nut: across-flats half-width, flats, half-height
            self.half = (0.017 * k, 0.017 * k, 0.009)
        self.period = math.pi / 3 if self.kind == "nut" else math.pi
        self.z = p.f("height")
        self.axis = np.array([p.f("x"), p.f("y")])
        self.init = p.f("init_angle")
        self.sign = 1.0 if p.value("direction") == "ccw" else -1.0
        self.target = self.init + self.sign * p.f("turn")

    def scene(self) -> Scene:
        p = self.p
        hx, hy, hz = self.half
        bottom = self.z - hz
        fr = f'friction="{p.f("part"):.4f} 0.005 0.0001"'
        if self.kind == "nut":
            r = hx / math.cos(math.pi / 6)
            verts = " ".join(
                f"{r * math.cos(math.pi / 6 + i * math.pi / 3):.5f} "
                f"{r * math.sin(math.pi / 6 + i * math.pi / 3):.5f} {zz:.5f}"
                for i in range(6)
                for zz in (-hz, hz)
            )
            assets = f'<mesh name="nut" vertex="{verts}"/>'
            handle = f'<geom type="mesh" mesh="nut" density="2000" {fr} rgba="0.7 0.7 0.75 1"/>'
            post = (
                f'<geom class="fixture" type="cylinder" pos="0 0 {(self.z + hz + 0.008) / 2:.5f}" '
                f'size="0.006 {(self.z + hz + 0.008) / 2:.5f}"/>'
                f'<geom class="fixture" type="cylinder" pos="0 0 {bottom / 2:.5f}" '
                f'size="{hx + 0.004:.5f} {bottom / 2:.5f}"/>'
            )
        else:
            assets = ""
            handle = (
                f'<geom type="box" size="{hx:.5f} {hy:.5f} {hz:.5f}" density="800" {fr} '
                f'rgba="0.8 0.2 0.2 1"/>'
            )
            if self.kind == "valve":
                handle += (
                    f'<geom type="cylinder" size="0.016 {hz * 0.6:.5f}" density="800" {fr} '
                    f'rgba="0.6 0.15 0.15 1"/>'
                )
            post = (
                f'<geom class="fixture" type="cylinder" pos="0 0 {bottom / 2:.5f}" '
                f'size="0.009 {bottom / 2:.5f}"/>'
            )
        return Scene(
            assets=assets,
            bodies=f"""
    <body name="base" pos="{self.axis[0]:.5f} {self.axis[1]:.5f} 0">{post}</body>
    <body name="knob" pos="{self.axis[0]:.5f} {self.axis[1]:.5f} {self.z:.5f}">
      <joint name="knob" type="hinge" axis="0 0 1" damping="{p.f('damping'):.4f}"
        frictionloss="{p.f('frictionloss'):.4f}" armature="0.0005"/>
      {handle}
    </body>""",
            contact='<exclude body1="knob" body2="base"/>',
        )

    def bind(self, sim: Sim) -> None:
        super().bind(sim)
        self.knob = sim.bid("knob")
        self.base = sim.bid("base")

    def reset(self, sim: Sim) -> None:
        sim.data.qpos[sim.model.joint("knob").qposadr[0]] = self.init

    def angle(self) -> float:
        return self.s.qpos("knob")

    def stages(self) -> tuple[str, ...]:
        return ("reach", "grasp", "turn", "release")

    def parts(self) -> np.ndarray:
        return self.pad([self.row(self.knob, self.angle()), self.row(self.base)])

    def goal(self) -> np.ndarray:
        return np.array([1.0, self.target, TOLERANCE, self.sign])

    def evaluate(self) -> Evaluation:
        s = self.s
        err = self.angle() - self.target
        grasped = s.grasping(self.knob)
        reached = abs(err) < TOLERANCE
        flags = {"grasped:knob": grasped, "turned:knob": reached}
        if reached:
            done = not s.touching(self.knob)
            return Evaluation("release", 0.0, done, flags)
        if grasped:
            return Evaluation("turn", 1.0 - abs(err) / abs(self.target - self.init), False, flags)
        ee = s.ee()
        top = np.array([*self.axis, self.z + self.half[2]])
        if np.linalg.norm(ee[:2] - self.axis) < 0.015 and ee[2] < top[2] + 0.005:
            return Evaluation("grasp", 0.0, False, flags)
        return Evaluation("reach", 1.0 - float(np.linalg.norm(ee[:3] - top)) / 0.3, False, flags)

    def truth(self) -> dict[str, Any]:
        lo, hi = self.target - TOLERANCE, self.target + TOLERANCE
        return truth_doc(
            self,
            [
                var("ee_pose", "pose"),
                var("gripper_width", "length"),
                var("knob_angle", "angle", "knob"),
                var("knob_grasped", "bool", "knob"),
                var("angle_error", "angle", "knob"),
            ],
            {
                "handle_kind": self.kind,
                "rotation_axis": "vertical",
                "grasp_symmetry": round(self.period, 6),
                "turn_direction": "ccw" if self.sign > 0 else "cw",
                "turn_angle": round(abs(self.target - self.init), 6),
                "angle_tolerance": TOLERANCE,
                "max_grip_width": WIDTH_MAX,
            },
            {
                "grasp": ["gripper_open", "gripper_at_knob"],
                "turn": ["knob_grasped"],
                "release": ["knob_at_goal"],
            },
            [
                crit("knob_angle", "within", [round(lo, 6), round(hi, 6)]),
                crit("knob_grasped", "==", False),
            ],
        )

    def plan(self, env: BenchEnv) -> Plan:
        s = self.s
        theta = self.angle()
        delta = self.target - theta
        yaw0 = nearest_yaw(theta, self.period, -delta / 2)
        open_w = min(WIDTH_MAX, 2 * self.half[1] + 0.035)
        tcp_z = self.z - self.half[2] + 0.003
        yield from move(env, np.array([*self.axis, self.z + 0.06]), yaw0, open_w, tol=0.004)
        yield from move(env, np.array([*self.axis, tcp_z]), yaw0, open_w, speed=0.6)
        yield from grip(env, 0.0, 6)
        for _ in range(120):  # turn, closing the loop on the measured angle
            err = self.target - self.angle()
            if abs(err) < 0.015:
                break
            ee = s.ee()
            step = float(np.clip(err, -0.1, 0.1))
            yield from move(env, np.array([*self.axis, tcp_z]), ee[3] + step, 0.0, max_steps=1)
        yield from hold(env, 3, 0.0)
        yield from grip(env, open_w, 6)
        ee = s.ee()
        yield from move(env, np.array([*ee[:2], self.z + 0.08]), ee[3], open_w, tol=0.005)
        yield from idle(env, open_w)
