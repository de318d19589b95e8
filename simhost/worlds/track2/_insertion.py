"""Insertion: pick up a standing peg and insert it into a hole of matching cross-section.

Parts: ``peg`` (free), ``hole`` (fixed walls on the table; the table is the hole's floor, which
the camera sees as the dark bottom of a blind hole: a visual disc or plate 0.5 mm thick).
Square and rect pegs are boxes in a box hole (yaw symmetry pi/2 and pi); a round peg is a
cylinder in an octagonal hole of inradius ``peg_half + clearance / 2``; a hex peg (wide
ranges only) is a hexagonal prism ``2 peg_half`` across flats in a hexagonal hole (pi/3).

Stages: ``reach -> grasp -> transport -> align -> insert -> release``.
Success: the peg's bottom is inside the hole at least ``depth_frac * hole_depth`` deep, it
stands upright (tilt < 0.3 rad), and the gripper no longer touches it.
Events: ``grasped``/``released``, ``lifted``, ``inserted`` (part ``peg``).
Goal vector (dev): ``[1, required depth (m), hole_depth (m), 0]``. ``info["value"]``: the
insertion depth (m).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ._bench import WIDTH_MAX, Scene, dress, hide, look, quat_z, rot2, wrap
from ._family import (
    Evaluation,
    FamilyTask,
    Plan,
    box_walls,
    crit,
    grip,
    hold,
    idle,
    move,
    nearest_yaw,
    pick,
    radial,
    servo,
    spiral,
    truth_doc,
    var,
)
from ._truth import TaskTruth

if TYPE_CHECKING:
    from ._family import Bench

WALL = 0.015
CHAMFER = 0.002  # the hole's rim is chamfered: it guides a peg up to 2 mm off centre
PERIODS = {"square": math.pi / 2, "rect": math.pi, "round": 2 * math.pi, "hex": math.pi / 3}


class InsertionTask(FamilyTask):
    family = "insertion"
    part_names = ("peg", "hole")
    max_steps = 300

    def __init__(self, params: Any, config: Any = None) -> None:
        super().__init__(params, config)
        p = params
        self.shape = str(p.value("shape"))
        self.a = p.f("peg_half")
        self.b = self.a * p.f("aspect") if self.shape == "rect" else self.a
        self.h = p.f("peg_height")
        self.c = p.f("clearance")
        self.depth = p.f("hole_depth")
        self.need = p.f("depth_frac") * self.depth
        self.period = PERIODS[self.shape]
        self.d0 = float(np.hypot(p.f("hole_x") - p.f("peg_x"), p.f("hole_y") - p.f("peg_y")))

    def scene(self) -> Scene:
        p = self.p
        fr = p.f("part")
        assets = ""
        if self.shape == "round":
            peg = f'<geom type="cylinder" size="{self.a:.5f} {self.h / 2:.5f}"'
            walls = radial(8, self.a + self.c / 2, WALL, self.depth, chamfer=CHAMFER)
        elif self.shape == "hex":
            r = self.a / math.cos(math.pi / 6)
            verts = " ".join(
                f"{r * math.cos(math.pi / 6 + i * math.pi / 3):.6f} "
                f"{r * math.sin(math.pi / 6 + i * math.pi / 3):.6f} {zz:.6f}"
                for i in range(6) for zz in (-self.h / 2, self.h / 2))
            assets = f'<mesh name="peg" vertex="{verts}"/>'
            peg = '<geom type="mesh" mesh="peg"'
            walls = radial(6, self.a + self.c / 2, WALL, self.depth, chamfer=CHAMFER)
        else:
            peg = f'<geom type="box" size="{self.a:.5f} {self.b:.5f} {self.h / 2:.5f}"'
            walls = box_walls(self.a + self.c / 2, self.b + self.c / 2, WALL, self.depth,
                              chamfer=CHAMFER)
        # the bore's bottom as the camera sees a blind hole: dark (visual only, under a peg
        # that reaches the table)
        ra, rb = self.a + self.c / 2, self.b + self.c / 2
        floor = (f'type="box" size="{ra:.5f} {rb:.5f} 0.00025"' if self.shape in ("square", "rect")
                 else f'type="cylinder" size="{ra:.5f} 0.00025"')
        floor = (f'<geom class="visual" {floor} pos="0 0 0.00025" material="wood_dark" '
                 f'rgba="0.2 0.17 0.15 1"/>')
        peg += (f' density="{p.f("density"):.2f}" friction="{fr:.4f} 0.005 0.0001" '
                f'rgba="0.85 0.45 0.2 1"/>')
        # what the camera sees: the asset library's peg (brass), scaled to this peg
        unit = {"round": "peg_round", "hex": "peg_hex"}.get(self.shape, "peg_square")
        wide = self.a if self.shape in ("round", "hex") else self.b
        assets += (f'<mesh name="peg_look" file="{unit}.obj" '
                   f'scale="{2 * self.a:.5f} {2 * wide:.5f} {self.h:.5f}"/>')
        peg = hide(peg) + look("peg_look", "brass")
        return Scene(
            assets=assets,
            bodies=f"""
    <body name="peg" pos="{p.f('peg_x'):.5f} {p.f('peg_y'):.5f} {self.h / 2 + 0.0005:.5f}"
      quat="{quat_z(p.f('peg_yaw'))}">
      <freejoint name="peg"/>
      {peg}
    </body>
    <body name="hole" pos="{p.f('hole_x'):.5f} {p.f('hole_y'):.5f} 0"
      quat="{quat_z(p.f('hole_yaw'))}">
      {dress(walls, "wood_dark")}{floor}
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

    def symmetry(self) -> tuple[float, ...]:
        return (self.period, self.period)

    def yaw_priors(self) -> dict[int, float]:
        return {0: self.p.f("peg_yaw"), 1: self.p.f("hole_yaw")}

    def goal(self) -> np.ndarray:
        return np.array([1.0, self.need, self.depth, 0.0])

    # -- reading (through an eye: the truth by default) ------------------------------------------
    def hole_xy(self, eye: Any = None) -> np.ndarray:
        return (eye or self.s).pos(self.hole)[:2]

    def hole_yaw(self, eye: Any = None) -> float:
        return float((eye or self.s).yaw(self.hole))

    def bottom(self, eye: Any = None) -> np.ndarray:
        return (eye or self.s).point(self.peg, (0.0, 0.0, -self.h / 2))

    def height(self, eye: Any = None) -> float:
        """The peg bottom's height above the hole's floor: measured against the hole's own
        measured pose, so that an error common to both (the camera's calibration) cancels."""
        e = eye or self.s
        return float(self.bottom(e)[2] - e.pos(self.hole)[2])

    def in_hole(self, xy: np.ndarray, margin: float = 0.002) -> bool:
        local = rot2(-self.hole_yaw(), xy - self.hole_xy())
        if self.shape in ("round", "hex"):
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
            return Evaluation("release", 1.0, True, flags, depth)
        if inserted:
            return Evaluation("release", 0.0, False, flags, depth)
        if entered:
            return Evaluation("insert", depth / self.need, False, flags, depth)
        off = float(np.linalg.norm(bot[:2] - self.hole_xy()))
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

    def truth(self) -> TaskTruth:
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
            {"depth_frac": self.p.f("depth_frac")},
        )

    # -- expert --------------------------------------------------------------------------------
    def plan(self, env: Bench) -> Plan:
        e = self.e
        peg_yaw = e.yaw(self.peg)
        hole_yaw = self.hole_yaw(e)
        # fingers close along the hand's y axis: across the peg's short side (or flats)
        base = peg_yaw + {"rect": math.pi / 2, "hex": math.pi / 6}.get(self.shape, 0.0)
        grasp_period = {"rect": math.pi, "hex": math.pi / 3}.get(self.shape, math.pi / 2)
        if self.shape == "round":
            turn, base, grasp_period = 0.0, 0.0, 2 * math.pi
        else:
            turn = nearest_yaw(hole_yaw - peg_yaw, self.period)
        yaw0 = nearest_yaw(base, grasp_period, -turn / 2)
        open_w = min(WIDTH_MAX, 2 * self.a + 0.03)
        g = min(0.022, self.h - self.depth - 0.006)
        top = e.point(self.peg, (0.0, 0.0, self.h / 2))
        lift = self.depth + 0.02 + self.h - g
        yield from pick(env, top, yaw0, open_w, g, lift)
        # carry above the hole, turning the peg into the hole's orientation
        for _ in range(3):
            ee, bot = env.sim.ee(), self.bottom(e)
            goal_xy = ee[:2] + self.hole_xy(e) - bot[:2]
            yield from move(env, np.array([*goal_xy, lift]), yaw0 + turn, 0.0, tol=0.003)
        yield from hold(env, 4, 0.0)  # let the estimates settle while still
        yield from self._align(env, lift)
        yield from self._descend(env)
        if self.height(e) > self.depth - 0.002:  # stuck on the rim: search around
            yield from self._search(env)
        yield from grip(env, open_w, 6)
        ee = env.sim.ee()
        yield from move(env, np.array([*ee[:2], ee[2] + 0.05]), ee[3], open_w, tol=0.005)
        yield from idle(env, open_w)

    def _align(self, env: Bench, z: float) -> Plan:
        """Servo the peg's bottom over the hole centre and its yaw onto the hole's."""
        e = self.e

        def error() -> tuple[np.ndarray, float]:
            err = self.hole_xy(e) - self.bottom(e)[:2]
            if self.shape == "round":
                return err, 0.0
            return err, wrap(nearest_yaw(self.hole_yaw(e) - e.yaw(self.peg), self.period))

        yield from servo(env, error, z)

    def _search(self, env: Bench) -> Plan:
        """Probe around the aligned position, nearest points first, until the peg drops in:
        what perception cannot settle (a part's pose error), contact does."""
        e = self.e
        ee = env.sim.ee()
        centre = ee[:2].copy()
        hover = ee[2] - (self.height(e) - (self.depth + 0.004))
        spacing = 0.8 * (CHAMFER + self.c / 2)
        for off in spiral(spacing, 4):
            yield from move(env, np.array([*(centre + off), hover]), ee[3], 0.0, tol=0.0015,
                            max_steps=6)
            for _ in range(4):  # press down a little; inside, the peg keeps going
                now = env.sim.ee()[2]
                yield from move(env, np.array([*(centre + off), now - 0.005]), ee[3], 0.0,
                                max_steps=1)
            if self.height(e) < self.depth - 0.003:
                yield from self._descend(env)
                return
            yield from move(env, np.array([*(centre + off), hover]), ee[3], 0.0, max_steps=2)

    def _descend(self, env: Bench) -> Plan:
        """Lower the peg: servo xy above the rim, hold xy once inside, stop when stuck."""
        e = self.e
        stuck = 0
        for _ in range(60):
            ee, z = env.sim.ee(), self.height(e)
            if z < 0.004 or self.depth - z > self.need + 0.004:
                return
            prev = ee[2]
            yield from move(env, np.array([*env.control_target[:2], ee[2] - 0.004]), ee[3], 0.0,
                            max_steps=1)
            stuck = stuck + 1 if env.sim.ee()[2] > prev - 0.0005 else 0
            if stuck >= 4:
                return
