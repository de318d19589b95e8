"""Opening/closing: move a drawer, a sliding cover or a swivel lid to a goal opening.

Parts rows: ``mover`` (the drawer, cover or lid; its ``joint`` is the slide position in m or
the swivel angle in rad) and ``housing`` (the fixed cabinet). The mechanism's frame sits at
``(x, y)`` turned by ``yaw``; its front faces -x. A drawer slides out along the frame's -x and
has a bar handle on standoffs; a cover slides along +y with a knob on top; a lid swivels about
a vertical pin at one corner with a knob at the opposite corner. A ``mirror``-ed cover slides
along -y, a mirrored lid is hinged at the other corner and swings clockwise. Joints have
damping and dry friction, so a mechanism stays where it is left (a lid's damping and dry
friction are the table's values times ``LID_LEVER`` = 0.1 m, i.e. the same force felt at its
knob).

Opening fraction = joint / range. ``mode == "open"``: starts at ``start_frac`` (jittered per
attempt), goal ``goal_frac``; ``mode == "close"``: starts at ``1 - start_frac``, goal
``1 - goal_frac``. The goal is the demonstration's fraction; the range differs between
instances, so the same fraction is a different joint value.
Stages: ``reach -> grasp -> open|close -> release``.
Success: fraction within ``tolerances.opening_frac`` of the goal and the gripper off the
mover. Events: ``grasped``/``released``, ``opened`` or ``closed`` (part = the kind: drawer,
cover, lid). Goal vector (dev): ``[1, goal fraction, tolerance, +1 open / -1 close]``.
``info["value"]``: the opening fraction.
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Any

import numpy as np

from ._bench import DARK, WIDTH_MAX, Scene, dress, quat_z, rot2, wrap, yaw_of
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
    reach_down,
    truth_doc,
    var,
)
from ._truth import TaskTruth

if TYPE_CHECKING:
    from ._family import Bench
    from ._sim import Sim

START_JITTER = 0.5  # start fraction jitter per radian of attempt_jitter_rad
HANDLE_Z = 0.06  # drawer bar height
BAR_X = -0.045  # drawer bar centre in front of the panel (panel front at -0.008)
LID_PIVOT = (0.05, 0.05)
LID_KNOB = (-0.09, -0.09)  # knob relative to the pivot at angle 0
LID_LEVER = 0.1  # m: a lid's damping and friction are the table's values times this
PART = {"drawer": "drawer", "sliding_cover": "cover", "swivel_lid": "lid"}


class OpeningTask(FamilyTask):
    family = "opening"
    part_names = ("mover", "housing")
    max_steps = 250

    def __init__(self, params: Any, config: Any = None) -> None:
        super().__init__(params, config)
        p = params
        self.kind = str(p.value("kind"))
        self.part = PART[self.kind]
        self.range = p.f("swing") if self.kind == "swivel_lid" else p.f("travel")
        self.k = p.f("handle_scale")
        self.open_mode = p.value("mode") == "open"
        self.sy = -1.0 if p.value("mirror") and self.kind != "drawer" else 1.0
        start, goal = p.f("start_frac"), p.f("goal_frac")
        self.start, self.goal_frac = (start, goal) if self.open_mode else (1 - start, 1 - goal)
        self.tolerance = self.tol.opening_frac
        self.knob_h = 0.012

    def scene(self) -> Scene:
        p, k = self.p, self.k
        fr = f'friction="{p.f("part"):.4f} 0.005 0.0001"'
        lever = LID_LEVER if self.kind == "swivel_lid" else 1.0  # N -> N m at the knob
        joint = (
            f'damping="{p.f("damping") * lever:.5f}" '
            f'frictionloss="{p.f("frictionloss") * lever:.5f}" '
            f'range="0 {self.range:.5f}" armature="{0.01 * lever:.5f}"'
        )
        wood = 'rgba="0.6 0.42 0.25 1"'
        knob = (
            f'<geom type="box" pos="{{x}} {{y}} {0.008 + self.knob_h:.5f}" '
            f'size="{0.012 * k:.5f} {0.012 * k:.5f} {self.knob_h:.5f}" {fr} rgba="0.2 0.2 0.2 1"/>'
        )
        plate = f'<geom type="box" pos="{{x}} {{y}} 0.004" size="0.062 0.062 0.004" {fr} {wood}/>'
        if self.kind == "drawer":
            bar_x = BAR_X
            inner = (
                f'<joint name="mover" type="slide" axis="-1 0 0" {joint}/>'
                f'<geom type="box" pos="0.05 0 0.035" size="0.05 0.06 0.025" {fr} {wood}/>'
                f'<geom type="box" pos="-0.004 0 0.045" size="0.004 0.068 0.04" {fr} {wood}/>'
                f'<geom type="box" pos="{bar_x} 0 {HANDLE_Z}" '
                f'size="{0.006 * k:.5f} {0.03 * k:.5f} {0.006 * k:.5f}" {fr} rgba="0.2 0.2 0.2 1"/>'
                + "".join(
                    f'<geom type="box" pos="{(BAR_X - 0.008) / 2:.5f} {s * 0.024 * k:.5f} '
                    f'{HANDLE_Z}" size="{-(BAR_X + 0.008) / 2:.5f} 0.004 0.004" {fr} '
                    f'rgba="0.2 0.2 0.2 1"/>'
                    for s in (-1, 1)
                )
            )
            housing = '<geom class="fixture" type="box" pos="0.06 0 0.045" size="0.06 0.07 0.045"/>'
            child = f'<body name="mover" pos="0 0 0">{_looks(inner)}</body>'
        else:
            housing = '<geom class="fixture" type="box" pos="0 0 0.025" size="0.06 0.06 0.025"/>'
            sy = self.sy
            if self.kind == "sliding_cover":
                inner = (
                    f'<joint name="mover" type="slide" axis="0 {sy:g} 0" {joint}/>'
                    + plate.format(x=0, y=0)
                    + knob.format(x=0, y=-0.03 * sy)
                )
                child = f'<body name="mover" pos="0 0 0.05">{_looks(inner)}</body>'
            else:
                px, py = LID_PIVOT[0], LID_PIVOT[1] * sy
                inner = (
                    f'<joint name="mover" type="hinge" axis="0 0 {sy:g}" {joint}/>'
                    + plate.format(x=-px, y=-py)
                    + knob.format(x=LID_KNOB[0], y=LID_KNOB[1] * sy)
                )
                child = f'<body name="mover" pos="{px} {py} 0.05">{_looks(inner)}</body>'
        housing = dress(housing, "wood_dark")
        return Scene(
            bodies=f"""
    <body name="housing" pos="{p.f('x'):.5f} {p.f('y'):.5f} 0"
      quat="{quat_z(p.f('yaw'))}">{housing}{child}</body>""",
            contact='<exclude body1="housing" body2="mover"/>',
        )

    def bind(self, sim: Sim) -> None:
        super().bind(sim)
        self.mover = sim.bid("mover")
        self.housing = sim.bid("housing")

    def reset(self, sim: Sim, jitter: float) -> None:
        frac = self.start + jitter * START_JITTER * self.config.attempt_jitter_rad
        self.start_now = float(np.clip(frac, 0.0, 1.0))
        sim.data.qpos[sim.model.joint("mover").qposadr[0]] = self.start_now * self.range

    def jitter_groups(self) -> tuple[tuple[str, ...], ...]:
        return (("housing",),)

    def row_reach(self) -> dict[int, float]:
        return {0: 0.2}

    @property
    def origin(self) -> np.ndarray:
        return self.s.model.body_pos[self.housing][:2].copy()

    @property
    def yaw(self) -> float:
        return yaw_of(self.s.model.body_quat[self.housing])

    def q(self) -> float:
        return self.s.qpos("mover")

    def q_seen(self, eye: Any) -> float:
        """The joint value from the mover's pose relative to the housing's (through ``eye``)."""
        h_xy, h_yaw = eye.pos(self.housing)[:2], eye.yaw(self.housing)
        local = rot2(-h_yaw, eye.pos(self.mover)[:2] - h_xy)
        if self.kind == "drawer":
            return float(-local[0])
        if self.kind == "sliding_cover":
            return float(local[1] * self.sy)
        return float(wrap(eye.yaw(self.mover) - h_yaw) * self.sy)

    def frac(self) -> float:
        return self.q() / self.range

    def held_rows(self) -> set[int]:
        return {0}

    def stages(self) -> tuple[str, ...]:
        return ("reach", "grasp", "open" if self.open_mode else "close", "release")

    def parts(self) -> np.ndarray:
        return self.pad([self.row(self.mover, self.q()), self.row(self.housing)])

    def goal(self) -> np.ndarray:
        return np.array([1.0, self.goal_frac, self.tolerance, 1.0 if self.open_mode else -1.0])

    # -- geometry of the grasp -------------------------------------------------------------------
    def grasp_pose(self, q: float, frame: tuple[np.ndarray, float] | None = None
                   ) -> tuple[np.ndarray, float]:
        """TCP position and a hand yaw that grasps the handle when the joint is at ``q``
        (the housing at ``frame``, default its true pose)."""
        origin, yaw = frame if frame is not None else (self.origin, self.yaw)
        if self.kind == "drawer":
            local, z, hand = (BAR_X - q, 0.0), HANDLE_Z - 0.004, yaw + math.pi / 2
        elif self.kind == "sliding_cover":
            local, z, hand = (0.0, self.sy * (-0.03 + q)), 0.058 + 0.003, yaw
        else:
            sy = self.sy
            local = np.array([LID_PIVOT[0], sy * LID_PIVOT[1]]) + rot2(
                sy * q, (LID_KNOB[0], sy * LID_KNOB[1]))
            z, hand = 0.058 + 0.003, yaw + sy * q
        xy = origin + rot2(yaw, local)
        return np.array([xy[0], xy[1], z]), hand

    def evaluate(self) -> Evaluation:
        s = self.s
        grasped = s.grasping(self.mover)
        frac = self.frac()
        err = frac - self.goal_frac
        reached = abs(err) < self.tolerance
        event = "opened" if self.open_mode else "closed"
        flags = {f"grasped:{self.part}": grasped, f"{event}:{self.part}": reached}
        if reached:
            return Evaluation("release", 0.0, not s.touching(self.mover), flags, frac)
        if grasped:
            span = max(abs(self.start - self.goal_frac), 1e-6)
            return Evaluation(self.stages()[2], 1.0 - abs(err) / span, False, flags, frac)
        ee = s.ee()
        target, _ = self.grasp_pose(self.q())
        if np.linalg.norm(ee[:2] - target[:2]) < 0.02 and ee[2] < target[2] + 0.02:
            return Evaluation("grasp", 0.0, False, flags, frac)
        dist = float(np.linalg.norm(ee[:3] - target))
        return Evaluation("reach", 1.0 - dist / 0.3, False, flags, frac)

    def truth(self) -> TaskTruth:
        verb = "open" if self.open_mode else "close"
        part = self.part
        tol = self.tolerance
        lo = max(0.0, self.goal_frac - tol)
        hi = min(1.0, self.goal_frac + tol)
        joint = {"drawer": "prismatic", "sliding_cover": "prismatic", "swivel_lid": "revolute"}
        return truth_doc(
            self,
            [
                var("ee_pose", "pose"),
                var("gripper_width", "length"),
                var(f"{part}_pose", "pose", part),
                var(f"{part}_opening", "fraction", part),
                var(f"{part}_grasped", "bool", part),
            ],
            {
                "mechanism": self.kind,
                "mirrored": self.sy < 0,
                "joint_type": joint[self.kind],
                "joint_range": round(self.range, 6),
                "direction": verb,
                "opening_tolerance": tol,
                "max_grip_width": WIDTH_MAX,
            },
            {
                "grasp": ["gripper_open", f"gripper_at_{part}_handle"],
                verb: [f"{part}_grasped"],
                "release": [f"{part}_at_goal"],
            },
            [
                crit(f"{part}_opening", "within", [round(lo, 6), round(hi, 6)]),
                crit(f"{part}_grasped", "==", False),
            ],
            {"fraction": round(self.goal_frac, 6), "mode": verb},
        )

    # -- expert --------------------------------------------------------------------------------
    def plan(self, env: Bench) -> Plan:
        e = self.e
        frame = (e.pos(self.housing)[:2], e.yaw(self.housing))
        q_goal = self.goal_frac * self.range
        lim = 0.08 if self.kind == "swivel_lid" else 0.01
        # a drawer's inner finger must fit between the bar and the panel
        open_w = 0.032 if self.kind == "drawer" else min(WIDTH_MAX, 0.024 * self.k + 0.04)
        for _ in range(3):  # grasp, drive, release; look again and correct if needed
            q0 = self.q_seen(e)
            pos, yaw = self.grasp_pose(q0, frame)
            _, yaw_end = self.grasp_pose(q_goal, frame)
            yaw0 = nearest_yaw(yaw, math.pi, -(yaw_end - yaw) / 2)
            yield from reach_down(env, pos, yaw0, open_w)
            yield from grip(env, 0.0, 6)
            for _ in range(150):
                q = self.q_seen(e)
                err = q_goal - q
                if abs(err) < self.tolerance * self.range / 4:
                    break
                q_next = q + float(np.clip(err, -lim, lim))
                # move the hand by the handle's predicted displacement, not to an absolute
                # pose: a calibration error common to the mechanism's parts cancels
                nxt, yaw_n = self.grasp_pose(q_next, frame)
                cur, yaw_c = self.grasp_pose(q, frame)
                ee = env.sim.ee()
                yield from move(env, ee[:3] + (nxt - cur), ee[3] + wrap(yaw_n - yaw_c), 0.0,
                                max_steps=1)
            yield from hold(env, 3, 0.0)
            yield from grip(env, open_w, 6)
            ee = env.sim.ee()
            yield from move(env, np.array([*ee[:2], ee[2] + 0.06]), ee[3], open_w, tol=0.005)
            yield from hold(env, 10, open_w)  # look at the mechanism again
            if abs(q_goal - self.q_seen(e)) < self.tolerance * self.range / 2:
                break
        yield from idle(env, open_w)



def _looks(inner: str) -> str:
    """The mover's geoms dressed: panels in light wood, grips (knobs, bars) in dark steel."""
    out = []
    for g in re.split(r"(?=<geom |<joint )", inner):
        if g.startswith("<geom "):
            g = dress(g, "steel", DARK) if 'rgba="0.2 0.2 0.2 1"' in g else dress(g, "wood_light")
        out.append(g)
    return "".join(out)
