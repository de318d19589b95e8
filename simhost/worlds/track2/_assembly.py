"""Assembly: stack two or three square parts, in order, into a tray and align them.

Parts: ``tray`` (fixed low walls on the table, drawn with a steel floor: a visual plate 0.5 mm
thick), ``part1``, ``part2``, ``part3`` (free boxes of decreasing
size; ``part3`` is a zero padding row when ``n_parts == 2``). ``part1`` goes into the tray,
each next part onto the previous one.

A part is *placed* when it rests on its support (tray floor or the previous part, height
within 5 mm), its centre is within ``tolerances.assembly_xy_m`` of the support's centre
(within the tray clearance plus 2 mm for ``part1``), its yaw matches the support's modulo
pi/2 within ``tolerances.assembly_yaw_rad`` — turned by 45 degrees on a ``diagonal`` stack
(``part2`` and ``part3``; the goal the demonstration shows) —, it is level, and the gripper
does not touch it.

Stages: ``reach_partK -> grasp_partK -> transport_partK -> place_partK`` for K = 1..n.
Success: every part placed. Events: ``grasped``/``released``, ``lifted``, ``placed``
(parts ``part1``..``part3``). The task states no goal: the goal vector is zero.
``info["value"]``: the number of parts placed.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ._bench import METAL, WIDTH_MAX, Scene, dress, quat_z, wrap
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
    servo,
    spiral,
    truth_doc,
    var,
)
from ._truth import TaskTruth

if TYPE_CHECKING:
    from ._family import Bench
    from ._sim import Sim

SCALES = (1.0, 0.85, 0.72)
WALL_H = 0.008
WALL_T = 0.012
TRAY_CHAMFER = 0.003  # the tray's rim is chamfered: it guides a part up to 3 mm off


class AssemblyTask(FamilyTask):
    family = "assembly"
    part_names = ("tray", "part1", "part2", "part3")
    max_steps = 600

    def __init__(self, params: Any, config: Any = None) -> None:
        super().__init__(params, config)
        p = params
        self.xy_tol = self.tol.assembly_xy_m
        self.yaw_tol = self.tol.assembly_yaw_rad
        self.n = int(p.value("n_parts"))
        self.names = [f"part{i + 1}" for i in range(self.n)]
        self.half = [p.f("part_half") * k for k in SCALES[: self.n]]
        self.H = p.f("part_height")
        self.clear = p.f("tray_clearance")
        self.turn = math.pi / 4 if p.value("stack") == "diagonal" else 0.0
        self.start = [
            np.array([p.f(f"p{i + 1}_x"), p.f(f"p{i + 1}_y"), p.f(f"p{i + 1}_yaw")])
            for i in range(self.n)
        ]

    def scene(self) -> Scene:
        fr = f'friction="{self.p.f("part"):.4f} 0.005 0.0001"'
        inner = self.half[0] + self.clear / 2
        walls = dress(box_walls(inner, inner, WALL_T, WALL_H, chamfer=TRAY_CHAMFER), "steel",
                      METAL)
        # the tray's floor as the camera sees it (visual only, 0.5 mm on the table, under
        # the walls and the parts placed on the table inside them)
        walls += (f'<geom class="visual" type="box" size="{inner + WALL_T:.5f} '
                  f'{inner + WALL_T:.5f} 0.00025" pos="0 0 0.00025" material="steel" '
                  f'rgba="0.62 0.64 0.68 1"/>')
        colours = ("0.2 0.6 0.3 1", "0.9 0.75 0.2 1", "0.3 0.4 0.85 1")
        bodies = [
            f'<body name="tray" pos="{self.p.f("tray_x"):.5f} {self.p.f("tray_y"):.5f} 0" '
            f'quat="{quat_z(self.p.f("tray_yaw"))}">{walls}</body>'
        ]
        for i, (name, h, st) in enumerate(zip(self.names, self.half, self.start, strict=True)):
            bodies.append(
                f'<body name="{name}" pos="{st[0]:.5f} {st[1]:.5f} {self.H / 2 + 0.0005:.5f}" '
                f'quat="{quat_z(st[2])}"><freejoint name="{name}"/>'
                + dress(f'<geom type="box" size="{h:.5f} {h:.5f} {self.H / 2:.5f}" '
                        f'density="{self.p.f("density"):.2f}" {fr} '
                        f'rgba="{colours[i]}"/>', "wood_light", None)
                + '</body>'
            )
        return Scene(bodies="\n    ".join(bodies))

    def bind(self, sim: Sim) -> None:
        super().bind(sim)
        self.tray = sim.bid("tray")
        self.ids = [sim.bid(n) for n in self.names]

    def loose_parts(self) -> dict[str, int]:
        return dict(zip(self.names, self.ids, strict=True))

    def jitter_groups(self) -> tuple[tuple[str, ...], ...]:
        return (("tray",), *((n,) for n in self.names))

    def row_refs(self) -> tuple[tuple[str, int] | None, ...]:
        rows: list[tuple[str, int] | None] = [("body", self.tray)]
        rows += [("body", b) for b in self.ids]
        return tuple(rows + [None] * (len(self.part_names) - len(rows)))

    def symmetry(self) -> tuple[float, ...]:
        return (math.pi / 2,) * len(self.part_names)

    def yaw_priors(self) -> dict[int, float]:
        out = {0: self.p.f("tray_yaw")}
        out.update({i + 1: float(st[2]) for i, st in enumerate(self.start)})
        return out

    def stages(self) -> tuple[str, ...]:
        subs = ("reach", "grasp", "transport", "place")
        return tuple(f"{sub}_{name}" for name in self.names for sub in subs)

    def parts(self) -> np.ndarray:
        return self.pad([self.row(self.tray), *(self.row(b) for b in self.ids)])

    # -- reading (through an eye: the truth by default) ------------------------------------------
    def support(self, i: int, eye: Any = None) -> tuple[np.ndarray, float, float]:
        """Centre xy, top z and yaw of what part ``i`` goes onto."""
        e = eye or self.s
        if i == 0:
            return e.pos(self.tray)[:2], 0.0, float(e.yaw(self.tray))
        b = self.ids[i - 1]
        pos = e.pos(b)
        return pos[:2], float(pos[2] + self.H / 2), float(e.yaw(b))

    def offsets(self, i: int, eye: Any = None) -> tuple[np.ndarray, float, float]:
        """Part ``i``'s xy offset, bottom height above and yaw error against its support."""
        e = eye or self.s
        xy, top, yaw = self.support(i, e)
        pos = e.pos(self.ids[i])
        dz = float(pos[2] - self.H / 2 - top)
        goal = yaw + (self.turn if i else 0.0)
        dyaw = wrap(nearest_yaw(goal - e.yaw(self.ids[i]), math.pi / 2))
        return xy - pos[:2], dz, dyaw

    def posed(self, i: int) -> bool:
        err, dz, dyaw = self.offsets(i)
        tol = self.clear / 2 + 0.002 if i == 0 else self.xy_tol
        return bool(
            np.linalg.norm(err) < tol
            and abs(dz) < 0.005
            and abs(dyaw) < self.yaw_tol
            and self.s.tilt(self.ids[i]) < 0.1
        )

    def evaluate(self) -> Evaluation:
        s = self.s
        flags: dict[str, bool] = {}
        first: int | None = None
        for i, (name, b) in enumerate(zip(self.names, self.ids, strict=True)):
            posed = self.posed(i)
            placed = posed and not s.touching(b)
            flags[f"grasped:{name}"] = s.grasping(b)
            flags[f"lifted:{name}"] = not posed and s.pos(b)[2] > self.H / 2 + 0.01
            flags[f"placed:{name}"] = placed
            if first is None and not placed:
                first = i
        placed = float(sum(flags[f"placed:{n}"] for n in self.names))
        if first is None:
            return Evaluation(self.stages()[-1], 1.0, True, flags, placed)
        i, name, b = first, self.names[first], self.ids[first]
        err, dz, _ = self.offsets(i)
        if self.posed(i):
            return Evaluation(f"place_{name}", 0.9, False, flags, placed)
        if s.grasping(b) and s.pos(b)[2] > self.H / 2 + 0.005:
            d = float(np.linalg.norm(err))
            if d < 0.015:
                return Evaluation(f"place_{name}", 0.8 * (1 - min(1.0, abs(dz) / 0.05)), False,
                                  flags, placed)
            d0 = float(np.linalg.norm(self.start[i][:2] - self.support(i)[0]))
            return Evaluation(f"transport_{name}", 1.0 - d / max(d0, 1e-6), False, flags, placed)
        ee, pos = s.ee(), s.pos(b)
        top = pos + np.array([0.0, 0.0, self.H / 2])
        if np.linalg.norm(ee[:2] - pos[:2]) < self.half[i] and ee[2] < top[2]:
            return Evaluation(f"grasp_{name}", 0.5 if s.grasping(b) else 0.0, False, flags, placed)
        dist = float(np.linalg.norm(ee[:3] - top))
        return Evaluation(f"reach_{name}", 1.0 - dist / 0.3, False, flags, placed)

    def truth(self) -> TaskTruth:
        variables = [var("ee_pose", "pose"), var("gripper_width", "length"),
                     var("tray_pose", "pose", "tray")]
        pre: dict[str, list[str]] = {}
        success = []
        for i, name in enumerate(self.names):
            below = "tray" if i == 0 else self.names[i - 1]
            variables += [
                var(f"{name}_pose", "pose", name),
                var(f"{name}_grasped", "bool", name),
                var(f"{name}_offset", "length", name),
                var(f"{name}_yaw_error", "angle", name),
                var(f"{name}_placed", "bool", name),
            ]
            pre[f"grasp_{name}"] = ["gripper_open", f"gripper_at_{name}"]
            pre[f"transport_{name}"] = [f"{name}_grasped"]
            pre[f"place_{name}"] = [f"{name}_grasped", f"{name}_over_{below}"] + (
                [f"{below}_placed"] if i else []
            )
            success.append(crit(f"{name}_placed", "==", True))
        return truth_doc(
            self,
            variables,
            {
                "n_parts": self.n,
                "order": ["tray", *self.names],
                "part_half_widths": [round(h, 6) for h in self.half],
                "part_height": round(self.H, 6),
                "tray_clearance": round(self.clear, 6),
                "xy_tolerance": self.xy_tol,
                "yaw_tolerance": self.yaw_tol,
                "yaw_symmetry": round(math.pi / 2, 6),
                "stack_yaw": round(self.turn, 6),
                "max_grip_width": WIDTH_MAX,
            },
            pre,
            success,
            {"n_parts": self.n, "stack": str(self.p.value("stack"))},
        )

    # -- expert --------------------------------------------------------------------------------
    def plan(self, env: Bench) -> Plan:
        e = self.e
        for i, b in enumerate(self.ids):
            for _ in range(3):  # place, look, and place again if it is off
                yield from self._place(env, i, b)
                yield from hold(env, 6, env.sim.width())
                err, dz, dyaw = self.offsets(i, e)
                tol = self.clear / 2 + 0.002 if i == 0 else self.xy_tol
                if (np.linalg.norm(err) < 0.7 * tol and abs(dyaw) < 0.7 * self.yaw_tol
                        and abs(dz) < 0.003):
                    break
        yield from idle(env)

    def _lower(self, env: Bench, i: int) -> Plan:
        """Lower part ``i`` onto its support (stops when it rests or cannot go lower)."""
        stuck = 0
        for _ in range(40):
            _, dz, _ = self.offsets(i, self.e)
            if dz < 0.001 or stuck >= 3:
                return
            ee = env.sim.ee()
            step = min(0.008, max(0.002, dz / 2))
            yield from move(env, np.array([*ee[:2], ee[2] - step]), ee[3], 0.0, max_steps=1)
            stuck = stuck + 1 if env.sim.ee()[2] > ee[2] - 0.0005 else 0

    def _place(self, env: Bench, i: int, b: int) -> Plan:
        """Pick part ``i`` where it lies, carry it over its support, lower it, let go."""
        e = self.e
        pos = e.pos(b)
        yaw = e.yaw(b)
        _, _, sup_yaw = self.support(i, e)
        turn = nearest_yaw(sup_yaw + (self.turn if i else 0.0) - yaw, math.pi / 2)
        yaw0 = nearest_yaw(yaw, math.pi / 2, -turn / 2)
        open_w = min(WIDTH_MAX, 2 * self.half[i] + 0.03)
        g = min(0.02, self.H - WALL_H - 0.004)
        carry = max(i, 1) * self.H + 0.025 + self.H - g
        yield from pick(env, pos + [0, 0, self.H / 2], yaw0, open_w, g, carry)
        for _ in range(2):
            err, _, _ = self.offsets(i, e)
            ee = env.sim.ee()
            yield from move(env, np.array([*(ee[:2] + err), carry]), yaw0 + turn, 0.0,
                            tol=0.003)
        yield from hold(env, 4, 0.0)  # let the estimates settle while still

        def error() -> tuple[np.ndarray, float]:
            err, _, dyaw = self.offsets(i, e)
            return err, dyaw

        yield from servo(env, error, carry, tol=0.001, yaw_tol=0.02)
        yield from self._lower(env, i)
        if i == 0 and self.offsets(i, e)[1] > 0.002:  # resting on the tray's rim: search
            centre, base = env.sim.ee()[:2].copy(), env.sim.ee()[2]
            for off in spiral(0.8 * (self.clear / 2 + TRAY_CHAMFER), 2):
                yield from move(env, np.array([*(centre + off), base + 0.006]),
                                env.sim.ee()[3], 0.0, tol=0.0015, max_steps=4)
                yield from self._lower(env, i)
                if self.offsets(i, e)[1] < 0.002:
                    break
        yield from hold(env, 2, 0.0)
        yield from grip(env, open_w, 6)
        ee = env.sim.ee()
        yield from move(env, np.array([*ee[:2], ee[2] + 0.04]), ee[3], open_w, tol=0.005)
