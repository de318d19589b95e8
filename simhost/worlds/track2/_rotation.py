"""Rotation: grasp a knob, valve handle or nut on a vertical hinge and turn it by a goal angle.

Parts: ``knob`` (hinged about z), ``base`` (fixed post, drawn on a round steel mounting plate:
visual only, 2 mm thick). Shapes: ``knob`` a short thick bar,
``valve`` a long thin bar over a hub, ``nut`` a hexagonal prism on a bolt. A bar is grasped
across its long sides (grasp symmetry pi), the nut across flats (pi/3); a pointer painted on
top shows the handle's angle over a full turn, so its reported yaw has no symmetry. The hinge has
damping and dry friction, so the handle stays where it is left, and a stop just behind the
start: it turns only in its ``direction`` (``ccw`` or ``cw``, seen from above).

The goal is a turn, relative to where the handle starts (the start is jittered per attempt):
``turn`` radians in ``direction``. Stages: ``reach -> grasp -> turn -> release``.
Success: the turned angle within ``tolerances.rotation_rad`` of the goal turn and the gripper
no longer touching the handle. Events: ``grasped``/``released``, ``turned`` (part ``knob``).
Goal vector (dev): ``[1, goal angle (rad, absolute), tolerance (rad), +1 ccw / -1 cw]``.
``info["value"]``: the angle turned so far (rad, + counter-clockwise).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ._bench import DARK, METAL, WIDTH_MAX, Scene, dress, hide, look, quat_z, wrap, yaw_of
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
from ._truth import TaskTruth

if TYPE_CHECKING:
    from ._family import Bench
    from ._sim import Sim

STOP = 0.05  # rad: the stop behind the start
FREE = 6.3  # rad: how far the handle may turn in its direction
PLATE_R = 0.045  # m: radius of the base's mounting plate (visual only)


class RotationTask(FamilyTask):
    family = "rotation"
    part_names = ("knob", "base")
    max_steps = 250

    def __init__(self, params: Any, config: Any = None) -> None:
        super().__init__(params, config)
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
        self.sign = 1.0 if p.value("direction") == "ccw" else -1.0
        self.turn = self.sign * p.f("turn")
        self.tolerance = self.tol.rotation_rad

    def scene(self) -> Scene:
        p = self.p
        hx, hy, hz = self.half
        lo, hi = (-STOP, FREE) if self.sign > 0 else (-FREE, STOP)
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
            top = self.z + hz + 0.008
            assets = (f'<mesh name="nut" vertex="{verts}"/>'
                      f'<mesh name="nut_look" file="hex_nut.obj" '
                      f'scale="{2 * hx:.5f} {2 * hx:.5f} {2 * hz / 0.9:.5f}"/>'
                      f'<mesh name="bolt_look" file="bolt.obj" scale="0.012 0.012 {top:.5f}"/>')
            handle = hide(f'<geom type="mesh" mesh="nut" density="2000" {fr} '
                          f'rgba="0.7 0.7 0.75 1"/>') + look("nut_look", "steel", rgba=METAL)
            post = (
                hide(f'<geom class="fixture" type="cylinder" pos="0 0 {top / 2:.5f}" '
                     f'size="0.006 {top / 2:.5f}"/>')
                + look("bolt_look", "steel", rgba=METAL)
                + dress(f'<geom class="fixture" type="cylinder" pos="0 0 {bottom / 2:.5f}" '
                        f'size="{hx + 0.004:.5f} {bottom / 2:.5f}"/>', "wood_dark")
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
                handle = dress(handle, "steel", None)
            else:  # a stove knob: a dark dial under its grip bar
                assets = (f'<mesh name="knob_look" file="gk_knob.stl" '
                          f'scale="{hx / 0.04875:.5f} {hx / 0.04875:.5f} {0.012 / 0.0539:.5f}"/>')
                handle = dress(handle, "steel", DARK) + look(
                    "knob_look", "steel", pos=f"0 0 {-hz - 0.012:.5f}", rgba=DARK)
            post = dress(
                f'<geom class="fixture" type="cylinder" pos="0 0 {bottom / 2:.5f}" '
                f'size="0.009 {bottom / 2:.5f}"/>', "steel", METAL)
        # The mechanism's mounting plate as the camera sees it (visual only, 2 mm on the
        # table, below anything the fingers reach): the base reads as a base from above,
        # where the handle hides its post.
        post += (f'<geom class="visual" type="cylinder" size="{PLATE_R} 0.001" pos="0 0 0.001" '
                 f'material="steel" rgba="{METAL}"/>')
        # A pointer painted on top (no collision): the handle's pose shows its angle over a
        # full turn, although its shape repeats every pi (bars) or pi/3 (the nut).
        handle += (
            f'<geom type="box" pos="{0.55 * hx:.5f} 0 {hz + 0.0006:.5f}" '
            f'size="{0.4 * hx:.5f} 0.0025 0.0006" contype="0" conaffinity="0" mass="0.0001" '
            f'rgba="0.95 0.95 0.2 1"/>'
        )
        return Scene(
            assets=assets,
            bodies=f"""
    <body name="knob" pos="{p.f('x'):.5f} {p.f('y'):.5f} {self.z:.5f}"
      quat="{quat_z(p.f('init_angle'))}">
      <joint name="knob" type="hinge" axis="0 0 1" damping="{p.f('damping'):.4f}"
        frictionloss="{p.f('frictionloss'):.4f}" armature="0.0005" range="{lo:.3f} {hi:.3f}"/>
      {handle}
    </body>
    <body name="base" pos="{p.f('x'):.5f} {p.f('y'):.5f} 0">{post}</body>""",
            contact='<exclude body1="knob" body2="base"/>',
        )

    def bind(self, sim: Sim) -> None:
        super().bind(sim)
        self.knob = sim.bid("knob")
        self.base = sim.bid("base")

    def jitter_groups(self) -> tuple[tuple[str, ...], ...]:
        return (("knob", "base"),)  # a yaw offset turns the handle's start (and its stop)

    @property
    def start(self) -> float:
        """The handle's angle at the start of this attempt (rad)."""
        return yaw_of(self.s.model.body_quat[self.knob])

    @property
    def axis(self) -> np.ndarray:
        return self.s.model.body_pos[self.knob][:2].copy()

    def angle(self) -> float:
        """The handle's angle (rad), continuous: start plus the hinge's turn."""
        return self.start + self.s.qpos("knob")

    def held_rows(self) -> set[int]:
        return {0}

    def stages(self) -> tuple[str, ...]:
        return ("reach", "grasp", "turn", "release")

    def parts(self) -> np.ndarray:
        return self.pad([self.row(self.knob, self.angle()), self.row(self.base)])

    def symmetry(self) -> tuple[float, ...]:
        return (2 * math.pi, 2 * math.pi)  # the pointer shows the angle over a full turn

    def yaw_priors(self) -> dict[int, float]:
        return {0: self.p.f("init_angle")}

    def goal(self) -> np.ndarray:
        return np.array([1.0, self.start + self.turn, self.tolerance, self.sign])

    def evaluate(self) -> Evaluation:
        s = self.s
        turned = self.s.qpos("knob")
        err = turned - self.turn
        grasped = s.grasping(self.knob)
        reached = abs(err) < self.tolerance
        flags = {"grasped:knob": grasped, "turned:knob": reached}
        if reached:
            done = not s.touching(self.knob)
            return Evaluation("release", 0.0, done, flags, turned)
        if grasped:
            return Evaluation("turn", 1.0 - abs(err) / abs(self.turn), False, flags, turned)
        ee = s.ee()
        axis = self.axis
        top = np.array([*axis, self.z + self.half[2]])
        if np.linalg.norm(ee[:2] - axis) < 0.015 and ee[2] < top[2] + 0.005:
            return Evaluation("grasp", 0.0, False, flags, turned)
        return Evaluation("reach", 1.0 - float(np.linalg.norm(ee[:3] - top)) / 0.3, False, flags,
                          turned)

    def truth(self) -> TaskTruth:
        tol = self.tolerance
        lo, hi = self.turn - tol, self.turn + tol
        return truth_doc(
            self,
            [
                var("ee_pose", "pose"),
                var("gripper_width", "length"),
                var("knob_angle", "angle", "knob"),
                var("knob_turn", "angle", "knob"),
                var("knob_grasped", "bool", "knob"),
            ],
            {
                "handle_kind": self.kind,
                "rotation_axis": "vertical",
                "grasp_symmetry": round(self.period, 6),
                "turn_direction": "ccw" if self.sign > 0 else "cw",
                "turn_angle": round(abs(self.turn), 6),
                "angle_tolerance": tol,
                "max_grip_width": WIDTH_MAX,
            },
            {
                "grasp": ["gripper_open", "gripper_at_knob"],
                "turn": ["knob_grasped"],
                "release": ["knob_at_goal"],
            },
            [
                crit("knob_turn", "within", [round(lo, 6), round(hi, 6)]),
                crit("knob_grasped", "==", False),
            ],
            {"turn": round(abs(self.turn), 6), "direction": "ccw" if self.sign > 0 else "cw"},
        )

    def plan(self, env: Bench) -> Plan:
        e = self.e
        theta = e.yaw(self.knob)  # continuous in the observed eye; unwrapped below
        target = theta + self.turn
        axis = e.pos(self.knob)[:2]
        open_w = min(WIDTH_MAX, 2 * self.half[1] + 0.035)
        tcp_z = self.z - self.half[2] + 0.003
        for _ in range(3):  # grasp, turn, release; look again and correct if needed
            yaw0 = nearest_yaw(theta, self.period, -(target - theta) / 2)
            yield from move(env, np.array([*axis, self.z + 0.06]), yaw0, open_w, tol=0.004)
            yield from move(env, np.array([*axis, tcp_z]), yaw0, open_w, speed=0.6)
            yield from grip(env, 0.0, 6)
            hand0 = env.sim.ee()[3]
            for _ in range(120):  # turn, dead-reckoning the handle on the hand's yaw
                err = target - (theta + env.sim.ee()[3] - hand0)
                if abs(err) < 0.012:
                    break
                ee = env.sim.ee()
                step = float(np.clip(err, -0.1, 0.1))
                yield from move(env, np.array([*axis, tcp_z]), ee[3] + step, 0.0, max_steps=1)
            yield from hold(env, 3, 0.0)
            yield from grip(env, open_w, 6)
            ee = env.sim.ee()
            yield from move(env, np.array([*ee[:2], self.z + 0.08]), ee[3], open_w, tol=0.005)
            yield from hold(env, 10, open_w)  # look at the handle again
            seen = e.yaw(self.knob)
            guess = theta + env.sim.ee()[3] - hand0
            theta = guess + wrap(seen - guess)
            if abs(target - theta) < self.tolerance / 2:
                break
        yield from idle(env, open_w)
