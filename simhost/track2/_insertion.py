"""Insertion: pick up a standing peg and insert it into a hole of matching cross-section.

Parts: ``peg`` (free), ``hole`` (fixed walls on the table; the table is the hole's floor).
Square and rect pegs are boxes in a box hole (yaw symmetry pi/2 and pi); a round peg is a
cylinder in an octagonal hole of inradius ``peg_half + clearance / 2``.

Stages: ``reach -> grasp -> transport -> align -> insert -> release``.
Success: the peg's bottom is inside the hole at least ``depth_frac * hole_depth`` deep, it
stands upright (tilt < 0.3 rad), and the gripper no longer touches it.
Events: ``grasped``/``released``, ``lifted``, ``inserted`` (part ``peg``).
Goal vector: ``[1, required depth (m), hole_depth (m), 0]``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ._bench import WIDTH_MAX, Scene, quat_z, rot2, wrap
from ._family import (
    Evaluation,
    FamilyTask,
    Plan,
    box_walls,
    crit,
    grip,
    idle,
    move,
    nearest_yaw,
    pick,
    radial,
    servo,
    truth_doc,
    var,
)

if TYPE_CHECKING:
    from ._env import BenchEnv

WALL = 0.015
DENSITY = 600.0


class InsertionTask(FamilyTask):
    family = "insertion"
    part_names = ("peg", "hole")
    max_steps = 300

    def __init__(self, params: Any) -> None:
        super().__init__(params)
        p = params
        self.shape = str(p.value("shape"))
        self.a = p.f("peg_half")
        self.b = self.a * p.f("aspect") if self.shape == "rect" else self.a
        self.h = p.f("peg_height")
        self.c = p.f("clearance")
        self.depth = p.f("hole_depth")
        self.need = p.f("depth_frac") * self.depth
        self.hole_xy = np.array([p.f("hole_x"), p.f("hole_y")])
        self.hole_yaw = p.f("hole_yaw")
        self.period = {"square": math.pi / 2, "rect": math.pi, "round": 2 * math.pi}[self.shape]
        self.d0 = float(np.linalg.norm(self.hole_xy - [p.f("peg_x"), p.f("peg_y")]))

    def scene(self) -> Scene:
        p = self.p
        fr = p.f("part")
        if self.shape == "round":
            peg = f'<geom type="cylinder" size="{self.a:.5f} {self.h / 2:.5f}"'
            walls = radial(8, self.a + self.c / 2, WALL, self.depth)
        else:
            peg = f'<geom type="box" size="{self.a:.5f} {self.b:.5f} {self.h / 2:.5f}"'
            walls = box_walls(self.a + self.c / 2, self.b + self.c / 2, WALL, self.depth)
        peg += f' density="{DENSITY}" friction="{fr:.4f} 0.005 0.0001" rgba="0.85 0.45 0.2 1"/>'
        return Scene(
            bodies=f"""
    <body name="peg" pos="{p.f('peg_x'):.5f} {p.f('peg_y'):.5f} {self.h / 2 + 0.0005:.5f}"
      quat="{quat_z(p.f('peg_yaw'))}">
      <freejoint name="peg"/>
      {peg}
    </body>
    <body name="hole" pos="{self.hole_xy[0]:.5f} {self.hole_xy[1]:.5f} 0"
      quat="{quat_z(self.hole_yaw)}">
      {''.join(walls)}
    </body>"""
        )

    def bind(self, sim: Any) -> None:
        super().bind(sim)
        self.peg = sim.bid("peg")
        self.hole = sim.bid("hole")

    def loose_parts(self) -> dict[str, int]:
        return {"peg": self.peg}

    def stages(self) -> tuple[str, ...]:
        return ("reach", "grasp", "transport", "align", "insert", "release")

    def parts(self) -> np.ndarray:
        return self.pad([self.row(self.peg), self.row(self.hole)])

    def goal(self) -> np.ndarray:
        return np.array([1.0, self.need, self.depth, 0.0])

    # -- reading -------------------------------------------------------------------------------
    def bottom(self) -> np.ndarray:
        return self.s.point(self.peg, (0.0, 0.0, -self.h / 2))

    def in_hole(self, xy: np.ndarray, margin: float = 0.002) -> bool:
        local = rot2(-self.hole_yaw, xy - self.hole_xy)
        if self.shape == "round":
            return bool(np.linalg.norm(local) < self.a + self.c / 2 + margin)
        return bool(
            abs(local[0]) < self.a + self.c / 2 + margin
            and abs(local[1]) < self.b + self.c / 2 + margin
        )

    def evaluate(self) -> Evaluation:
        s = self.s
        bot = self.bottom()
        inside = self.in_hole(bot[:2])
        depth = self.depth - float(bot[2]) if inside else 0.0
        entered = inside and bot[2] < self.depth - 0.002
        grasped = s.grasping(self.peg)
        lifted = bool(bot[2] > 0.01) and not entered
        upright = s.tilt(self.peg) < 0.3
        inserted = entered and depth >= self.need - 1e-4 and upright
        flags = {"grasped:peg": grasped, "lifted:peg": lifted, "inserted:peg": inserted}
        touching = s.touching(self.peg)
        if inserted and not touching:
            return Evaluation("release", 1.0, True, flags)
        if inserted:
            return Evaluation("release", 0.0, False, flags)
        if entered:
            return Evaluation("insert", depth / self.need, False, flags)
        off = float(np.linalg.norm(bot[:2] - self.hole_xy))
        if grasped and lifted:
            if off < 0.02:
                return Evaluation("align", 1.0 - off / 0.02, False, flags)
            return Evaluation("transport", 1.0 - off / max(self.d0, 1e-6), False, flags)
        ee = s.ee()
        top = s.point(self.peg, (0.0, 0.0, self.h / 2))
        dist = float(np.linalg.norm(ee[:3] - top))
        if np.linalg.norm(ee[:2] - top[:2]) < self.a + 0.01 and ee[2] < top[2]:
            return Evaluation("grasp", 0.5 if grasped else 0.0, False, flags)
        return Evaluation("reach", 1.0 - dist / 0.3, False, flags)

    def truth(self) -> dict[str, Any]:
        return truth_doc(
            self,
            [
                var("ee_pose", "pose"),
                var("gripper_width", "length"),
                var("peg_pose", "pose", "peg"),
                var("hole_pose", "pose", "hole"),
                var("peg_grasped", "bool", "peg"),
                var("peg_lifted", "bool", "peg"),
                var("peg_hole_offset", "length", "peg"),
                var("peg_yaw_error", "angle", "peg"),
                var("insertion_depth", "length", "peg"),
            ],
            {
                "peg_shape": self.shape,
                "clearance": round(self.c, 6),
                "yaw_symmetry": round(self.period, 6),
                "hole_depth": round(self.depth, 6),
                "peg_upright": True,
                "max_grip_width": WIDTH_MAX,
            },
            {
                "grasp": ["gripper_open", "gripper_at_peg"],
                "transport": ["peg_grasped"],
                "align": ["peg_grasped", "peg_lifted"],
                "insert": ["peg_grasped", "peg_aligned"],
                "release": ["peg_inserted"],
            },
            [
                crit("insertion_depth", ">=", round(self.need, 6)),
                crit("peg_hole_offset", "<=", round(self.c / 2 + 0.002, 6)),
                crit("peg_grasped", "==", False),
            ],
        )

    # -- expert --------------------------------------------------------------------------------
    def plan(self, env: BenchEnv) -> Plan:
        s = self.s
        peg_yaw = s.yaw(self.peg)
        # fingers close along the hand's y axis: across the peg's short side
        base = peg_yaw + (math.pi / 2 if self.shape == "rect" else 0.0)
        grasp_period = math.pi if self.shape == "rect" else (math.pi / 2)
        if self.shape == "round":
            turn, base, grasp_period = 0.0, 0.0, 2 * math.pi
        else:
            turn = nearest_yaw(self.hole_yaw - peg_yaw, self.period)
        yaw0 = nearest_yaw(base, grasp_period, -turn / 2)
        open_w = min(WIDTH_MAX, 2 * self.a + 0.03)
        g = min(0.022, self.h - self.depth - 0.006)
        top = s.point(self.peg, (0.0, 0.0, self.h / 2))
        lift = self.depth + 0.02 + self.h - g
        yield from pick(env, top, yaw0, open_w, g, lift)
        # carry above the hole, turning the peg into the hole's orientation
        for _ in range(3):
            ee, bot = s.ee(), self.bottom()
            goal_xy = ee[:2] + self.hole_xy - bot[:2]
            yield from move(env, np.array([*goal_xy, lift]), yaw0 + turn, 0.0, tol=0.003)
        for _attempt in range(3):
            yield from self._align(env, lift)
            yield from self._descend(env)
            if self.bottom()[2] < self.depth - 0.002:
                break
            ee = s.ee()
            yield from move(env, np.array([*ee[:2], lift]), ee[3], 0.0, tol=0.003)
        yield from grip(env, open_w, 6)
        ee = s.ee()
        yield from move(env, np.array([*ee[:2], ee[2] + 0.05]), ee[3], open_w, tol=0.005)
        yield from idle(env, open_w)

    def _align(self, env: BenchEnv, z: float) -> Plan:
        """Servo the peg's bottom over the hole centre and its yaw onto the hole's."""

        def error() -> tuple[np.ndarray, float]:
            err = self.hole_xy - self.bottom()[:2]
            if self.shape == "round":
                return err, 0.0
            return err, wrap(nearest_yaw(self.hole_yaw - self.s.yaw(self.peg), self.period))

        yield from servo(env, error, z)

    def _descend(self, env: BenchEnv) -> Plan:
        """Lower the peg: servo xy above the rim, hold xy once inside, stop when stuck."""
        s = self.s
        stuck = 0
        for _ in range(60):
            ee, bot = s.ee(), self.bottom()
            if bot[2] < 0.004 or self.depth - bot[2] > self.need + 0.004:
                return
            xy = ee[:2] + (self.hole_xy - bot[:2]) if bot[2] > self.depth + 0.002 else None
            if xy is None:
                xy = env.control_target[:2]
            prev = bot[2]
            yield from move(env, np.array([*xy, ee[2] - 0.004]), ee[3], 0.0, max_steps=1)
            stuck = stuck + 1 if self.bottom()[2] > prev - 0.0005 else 0
            if stuck >= 4:
                return
