"""Scripted controllers for the five bench families, closed on the observations only.

Each controller is a generator of actions ``[dx, dy, dz, dyaw, grip]`` that reads part poses
through a :class:`View` (a :class:`~perception.Perception` plus the exact proprioception; the
agent updates it after every reply). Bench facts used here are public (the track README):
per-step limits, the hand's lead, the gripper's size, the mechanisms' handle geometry. What
the observation cannot show comes from the demonstration, passed in ``hints``:

- ``turn``: the signed angle the demonstration turned (rad);
- ``fraction``: the opening fraction it left a mechanism at;
- ``mechanism``: ``press`` or ``pull`` (its last key stage);
- ``slot``: the tool slot the demonstration took its tool from (the longer tool when that
  slot is empty);

and a controller falls back to a plain guess when the packet does not say.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from perception import Perception, rot2, wrap

DPOS, DYAW, WMAX = 0.015, 0.15, 0.09
LEAD = np.array([0.02, 0.02, 0.02, 0.3])
LO = np.array([-0.30, -0.30, 0.003, -3.2])
HI = np.array([0.30, 0.30, 0.30, 3.2])
Plan = Iterator[np.ndarray]

# Which rows a family's gripper may carry or drive, and how far their frame sits from it.
MOVABLE: dict[str, tuple[set[int], dict[int, float], dict[int, int]]] = {
    "insertion": ({0}, {}, {}),
    "rotation": ({0}, {}, {}),
    "assembly": ({1, 2, 3}, {}, {}),
    "opening": ({0}, {0: 0.2}, {}),
    "tool_use": ({0, 2}, {}, {1: 0, 3: 2}),
}


def nearest_yaw(yaw: float, period: float, near: float = 0.0) -> float:
    return near + (yaw - near + period / 2) % period - period / 2


class View:
    """Perception, the exact proprioception, and a mirror of the hand's control target.

    The bench moves the target by the action (scaled), keeps it within ``LEAD`` of the hand
    and inside the workspace; mirroring that makes a move land where it is aimed.
    """

    def __init__(self, family: str, rows: int, rigs: tuple[set[int], dict[int, float],
                                                         dict[int, int]] | None = None) -> None:
        movable, reach, links = rigs if rigs is not None else MOVABLE[family]
        self.p = Perception(rows, movable, reach, links)
        self.obs: dict[str, np.ndarray] = {}
        self.prev_ee = np.zeros(4)
        self.target = np.zeros(4)

    def update(self, obs: dict[str, Any], *, reset: bool = False) -> None:
        self.prev_ee = self.ee() if self.obs and not reset else np.asarray(obs["proprio"][:4])
        self.obs = {k: np.asarray(v, dtype=float) for k, v in obs.items()
                    if isinstance(v, np.ndarray) and k in ("proprio", "parts", "force")}
        self.p.update(self.obs)
        if reset:
            self.target = self.ee().copy()

    def ee(self) -> np.ndarray:
        return self.obs["proprio"][:4].copy()

    def width(self) -> float:
        return float(self.obs["proprio"][4])

    def speed(self) -> float:
        return float(np.linalg.norm(self.ee()[:2] - self.prev_ee[:2])) * 20.0

    def pos(self, i: int) -> np.ndarray:
        return self.p.pos(i)

    def yaw(self, i: int) -> float:
        return self.p.yaw(i)

    def present(self, i: int) -> bool:
        return bool(self.p.present[i])

    def command(self, goal: Any, yaw: float, width: float, speed: float = 1.0) -> np.ndarray:
        goal = np.clip(np.asarray(goal, dtype=float), LO[:3], HI[:3])
        d = goal - self.target[:3]
        n = float(np.linalg.norm(d))
        if n > speed * DPOS:
            d *= speed * DPOS / n
        dyaw = float(np.clip(wrap(yaw - self.target[3]), -speed * DYAW, speed * DYAW))
        a = np.zeros(5)
        a[:3] = np.clip(d / DPOS, -1, 1)
        a[3] = np.clip(dyaw / DYAW, -1, 1)
        a[4] = np.clip(2 * width / WMAX - 1, -1, 1)
        q = self.ee()
        t = self.target + a[:4] * np.array([DPOS, DPOS, DPOS, DYAW])
        self.target = np.clip(np.clip(t, q - LEAD, q + LEAD), LO, HI)
        return a


# -- primitives (the shapes of the bench's scripted expert, on observations) ------------------
def move(v: View, goal: Any, yaw: float, width: float, *, speed: float = 1.0,
         tol: float = 0.002, max_steps: int = 80) -> Plan:
    goal = np.clip(np.asarray(goal, dtype=float), LO[:3], HI[:3])
    for _ in range(max_steps):
        yield v.command(goal, yaw, width, speed)
        ee = v.ee()
        if np.linalg.norm(ee[:3] - goal) < tol and abs(wrap(yaw - ee[3])) < 0.03:
            return


def hold(v: View, steps: int, width: float) -> Plan:
    for _ in range(steps):
        yield v.command(v.target[:3], v.target[3], width)


def grip(v: View, width: float, steps: int = 6) -> Plan:
    """Close, or open gently (6 mm per step), and wait."""
    now = v.width()
    if width > now + 0.006:
        for w in np.arange(now + 0.006, width, 0.006):
            yield v.command(v.target[:3], v.target[3], float(w))
    yield from hold(v, steps, width)


def pick(v: View, top: np.ndarray, yaw: float, open_w: float, depth: float, lift: float) -> Plan:
    yield from move(v, [top[0], top[1], top[2] + 0.04], yaw, open_w, tol=0.004)
    yield from move(v, [top[0], top[1], top[2] - depth], yaw, open_w, speed=0.6)
    yield from grip(v, 0.0, 6)
    ee = v.ee()
    yield from move(v, [ee[0], ee[1], lift], yaw, 0.0, tol=0.004)


def servo(v: View, error: Callable[[], tuple[np.ndarray, float]], z: float, *,
          tol: float = 0.0008, yaw_tol: float = 0.02, max_steps: int = 40) -> Plan:
    for _ in range(max_steps):
        err, yaw_err = error()
        ee = v.ee()
        if np.linalg.norm(err) < tol and abs(yaw_err) < yaw_tol and v.speed() < 0.003:
            return
        yield from move(v, [ee[0] + err[0], ee[1] + err[1], z], ee[3] + yaw_err, 0.0,
                        max_steps=1)


def release(v: View, open_w: float, up: float) -> Plan:
    yield from grip(v, open_w, 6)
    ee = v.ee()
    yield from move(v, [ee[0], ee[1], ee[2] + up], ee[3], open_w, tol=0.005)


def look(v: View, steps: int = 8) -> Plan:
    """Hold still while measurements accumulate."""
    yield from hold(v, steps, v.width())


# -- families ---------------------------------------------------------------------------------
def insertion(v: View, hints: dict[str, Any]) -> Plan:
    yield from look(v, 6)
    h = 2 * max(v.pos(0)[2], 0.02)
    hole_xy, hole_yaw = v.pos(1)[:2], v.yaw(1)
    peg_yaw = v.yaw(0)
    # Reported yaws are folded by the parts' (same) symmetry: turning the peg by their
    # difference aligns the shapes, whatever the symmetry is.
    turn = wrap(hole_yaw - peg_yaw)
    yaw0 = nearest_yaw(peg_yaw, math.pi / 2, -turn / 2)
    g = 0.022
    lift = 0.05 + h - g

    def bottom() -> np.ndarray:
        return v.p.point(0, -h / 2)

    yield from pick(v, v.pos(0) + [0, 0, h / 2], yaw0, WMAX, g, lift)
    for _ in range(3):
        ee = v.ee()
        yield from move(v, [*(ee[:2] + hole_xy - bottom()[:2]), lift], yaw0 + turn, 0.0, tol=0.003)

    def error() -> tuple[np.ndarray, float]:
        return hole_xy - bottom()[:2], wrap(hole_yaw - v.yaw(0))

    for _ in range(3):
        yield from look(v, 4)
        yield from servo(v, error, lift)
        stuck = 0
        for _ in range(60):
            ee, bot = v.ee(), bottom()
            if bot[2] < 0.004:
                break
            prev = ee[2]
            yield from move(v, [*v.target[:2], ee[2] - 0.004], ee[3], 0.0, max_steps=1)
            stuck = stuck + 1 if v.ee()[2] > prev - 0.0005 else 0
            if stuck >= 4:
                break
        if bottom()[2] < 0.012:
            break
        ee = v.ee()
        yield from move(v, [*ee[:2], lift], ee[3], 0.0, tol=0.003)
    yield from release(v, WMAX, 0.05)


def rotation(v: View, hints: dict[str, Any]) -> Plan:
    yield from look(v, 6)
    axis, z = v.pos(0)[:2], v.pos(0)[2]
    turn = float(hints.get("turn", 1.0))
    theta = v.yaw(0)
    yaw0 = nearest_yaw(theta, math.pi, -turn / 2)  # pi: right for bars and nuts alike
    tcp_z = z - 0.005
    yield from move(v, [*axis, z + 0.06], yaw0, 0.08, tol=0.004)
    yield from move(v, [*axis, tcp_z], yaw0, 0.08, speed=0.6)
    yield from grip(v, 0.0, 6)
    hand0 = v.ee()[3]
    for _ in range(120):
        err = turn - (v.ee()[3] - hand0)
        if abs(err) < 0.012:
            break
        ee = v.ee()
        yield from move(v, [*axis, tcp_z], ee[3] + float(np.clip(err, -0.1, 0.1)), 0.0,
                        max_steps=1)
    yield from hold(v, 3, 0.0)
    yield from release(v, 0.08, 0.06)


SCALES = (1.0, 0.85, 0.72)


def assembly(v: View, hints: dict[str, Any]) -> Plan:
    yield from look(v, 6)
    n = sum(v.present(i) for i in (1, 2, 3))
    height = 2 * max(v.pos(1)[2], 0.012)
    for i in range(n):
        row = i + 1
        sup = 0 if i == 0 else row - 1

        def support(sup: int = sup) -> tuple[np.ndarray, float, float]:
            if sup == 0:
                return v.pos(0)[:2], 0.0, v.yaw(0)
            return v.pos(sup)[:2], float(v.pos(sup)[2] + height / 2), v.yaw(sup)

        def offsets(row: int = row) -> tuple[np.ndarray, float, float]:
            xy, top, yaw = support()
            p = v.pos(row)
            return (xy - p[:2], float(p[2] - height / 2 - top),
                    wrap(nearest_yaw(yaw - v.yaw(row), math.pi / 2)))

        yaw = v.yaw(row)
        turn = nearest_yaw(support()[2] - yaw, math.pi / 2)
        yaw0 = nearest_yaw(yaw, math.pi / 2, -turn / 2)
        g = min(0.02, height - 0.012)
        carry = max(i, 1) * height + 0.025 + height - g
        yield from pick(v, v.pos(row) + [0, 0, height / 2], yaw0, WMAX, g, carry)
        for _ in range(2):
            ee = v.ee()
            yield from move(v, [*(ee[:2] + offsets()[0]), carry], yaw0 + turn, 0.0, tol=0.003)
        yield from look(v, 4)
        yield from servo(v, lambda offsets=offsets: (offsets()[0], offsets()[2]), carry,
                         tol=0.001, yaw_tol=0.02)
        for _ in range(40):
            dz = offsets()[1]
            if dz < 0.001:
                break
            ee = v.ee()
            yield from move(v, [*ee[:2], ee[2] - min(0.008, max(0.002, dz / 2))], ee[3], 0.0,
                            max_steps=1)
        yield from hold(v, 2, 0.0)
        yield from release(v, WMAX, 0.04)


BAR_X, HANDLE_Z, LID_PIVOT, LID_KNOB = -0.045, 0.06, (0.05, 0.05), (-0.09, -0.09)


def opening_kind(v: View) -> str:
    """drawer, sliding_cover or swivel_lid, from where the mover sits on its housing."""
    local = rot2(-v.yaw(1), v.pos(0)[:2] - v.pos(1)[:2])
    if v.pos(0)[2] < 0.025:
        return "drawer"
    return "swivel_lid" if np.linalg.norm(local - LID_PIVOT) < 0.03 else "sliding_cover"


def joint(v: View, kind: str) -> float:
    """The mechanism's joint value, from the mover's pose relative to the housing's."""
    local = rot2(-v.yaw(1), v.pos(0)[:2] - v.pos(1)[:2])
    if kind == "drawer":
        return float(-local[0])
    if kind == "sliding_cover":
        return float(local[1])
    return float(wrap(v.yaw(0) - v.yaw(1)))


def opening(v: View, hints: dict[str, Any]) -> Plan:
    yield from look(v, 8)
    kind = opening_kind(v)
    origin, frame = v.pos(1)[:2], v.yaw(1)
    opens = hints.get("mode", "open") == "open"
    goal_frac = float(hints.get("fraction", 0.8 if opens else 0.2))

    def grasp(q: float) -> tuple[np.ndarray, float]:
        if kind == "drawer":
            local, z, yaw = (BAR_X - q, 0.0), HANDLE_Z - 0.004, frame + math.pi / 2
        elif kind == "sliding_cover":
            local, z, yaw = (0.0, -0.03 + q), 0.061, frame
        else:
            local, z, yaw = np.array(LID_PIVOT) + rot2(q, LID_KNOB), 0.061, frame + q
        xy = origin + rot2(frame, local)
        return np.array([xy[0], xy[1], z]), yaw

    q0 = joint(v, kind)
    pos, yaw = grasp(q0)
    limit_guess = 1.6 if kind == "swivel_lid" else 0.14
    _, yaw_end = grasp(limit_guess)
    yaw0 = nearest_yaw(yaw, math.pi, -(yaw_end - yaw) / 2)
    open_w = 0.032 if kind == "drawer" else 0.07
    lim = 0.08 if kind == "swivel_lid" else 0.01
    yield from move(v, pos + [0, 0, 0.05], yaw0, open_w, tol=0.004)
    yield from move(v, pos, yaw0, open_w, speed=0.6)
    yield from grip(v, 0.0, 6)

    def drive(q_goal: float, probe: bool) -> Plan:
        start = best = joint(v, kind)
        still = 0
        for _ in range(150):
            q = joint(v, kind)
            if probe:  # open until the joint stops: that is its range
                still = still + 1 if q < best + 0.1 * lim else 0
                best = max(best, q)
                if (still >= 6 and best > start + 2 * lim) or still >= 14:
                    hints["range"] = hints["range_measured"] = best
                    return
            elif abs(q_goal - q) < 0.02 * hints["range"]:
                return
            nxt, yaw_n = grasp(q + float(np.clip(q_goal - q, -lim, lim)))
            yield from move(v, nxt, yaw0 + wrap(yaw_n - yaw), 0.0, max_steps=1)

    hints.setdefault("range", limit_guess)
    if "range_measured" not in hints:
        yield from drive(limit_guess, probe=True)
    yield from drive(goal_frac * hints["range"], probe=False)
    yield from hold(v, 3, 0.0)
    yield from release(v, open_w, 0.06)


def pick_tool(v: View, press: bool) -> tuple[int, float]:
    """The slot of the longer tool (the short one is a distractor) and its length."""
    best, length = 0, -1.0
    for slot in (0, 1):
        if not v.present(2 * slot):
            continue
        d = v.pos(2 * slot) - v.pos(2 * slot + 1)
        n = float(d[2] - 0.015) if press else float(np.linalg.norm(d[:2]))
        if n > length:
            best, length = slot, n
    return best, length


def tool_use(v: View, hints: dict[str, Any]) -> Plan:
    yield from look(v, 6)
    press = hints.get("mechanism", "press") == "press"
    slot = int(hints.get("slot", -1))
    if slot not in (0, 1) or not v.present(2 * slot):  # the demonstration's slot is empty
        slot, _ = pick_tool(v, press)
    tool, tip = 2 * slot, 2 * slot + 1
    tool_yaw = v.yaw(tool)
    top = v.p.point(tool, 0.015 if press else 0.03)
    if press:
        yaw0 = nearest_yaw(tool_yaw, math.pi / 2)
        depth = 0.054
        yield from pick(v, top, yaw0, 0.045, depth, top[2] - depth + 0.075)
        target = v.pos(4)[:2]
        z = 0.10 + (v.ee()[2] - v.pos(tip)[2])  # the tip 10 cm up clears any well's walls
        for _ in range(3):
            ee = v.ee()
            yield from move(v, [*(ee[:2] + target - v.pos(tip)[:2]), z], ee[3], 0.0, tol=0.003)
        yield from look(v, 4)
        yield from servo(v, lambda: (target - v.pos(tip)[:2], 0.0), z, tol=0.0015)
        stuck = 0
        for _ in range(100):  # push down until the button stops the tool
            ee = v.ee()
            xy = ee[:2] + target - v.pos(tip)[:2]
            prev = ee[2]
            yield from move(v, [*xy, ee[2] - 0.004], ee[3], 0.0, max_steps=1)
            stuck = stuck + 1 if v.ee()[2] > prev - 0.0005 else 0
            if stuck >= 4:
                break
        yield from hold(v, 5, 0.0)
        return
    turn = wrap(0.0 - tool_yaw)
    yaw0 = nearest_yaw(tool_yaw, math.pi, -turn / 2)
    yield from pick(v, top, yaw0, 0.045, min(0.054, top[2] - 0.004), 0.08)
    ee = v.ee()
    yield from move(v, [*ee[:2], 0.08], yaw0 + turn, 0.0, tol=0.004, speed=0.7)
    yield from look(v, 4)
    puck, goal_x = v.pos(4), float(v.pos(5)[0])
    for _ in range(3):
        ee, tp = v.ee(), v.pos(tip)
        want = np.array([puck[0] + 0.05, puck[1]])
        yield from move(v, [*(ee[:2] + want - tp[:2]), ee[2] - (tp[2] - 0.04)], yaw0 + turn, 0.0,
                        tol=0.003)
    ee, tp = v.ee(), v.pos(tip)
    yield from move(v, [*ee[:2], ee[2] - (tp[2] - 0.003)], yaw0 + turn, 0.0, speed=0.5,
                    tol=0.002)
    for _ in range(150):
        puck = v.pos(4)
        if puck[0] - goal_x < 0.004:
            break
        ee, tp = v.ee(), v.pos(tip)
        speed = 0.008 if puck[0] - goal_x > 0.03 else 0.003
        yield from move(v, [ee[0] - speed, ee[1] + 0.5 * (puck[1] - tp[1]),
                            ee[2] - (tp[2] - 0.003)], yaw0 + turn, 0.0, max_steps=1)
    yield from hold(v, 5, 0.0)


CONTROLLERS: dict[str, Callable[[View, dict[str, Any]], Plan]] = {
    "insertion": insertion, "rotation": rotation, "assembly": assembly, "opening": opening,
    "tool_use": tool_use,
}
