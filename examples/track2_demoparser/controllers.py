"""Scripted controllers for the five bench families, closed on the observations only.

Each controller is a generator of actions ``[dx, dy, dz, dyaw, grip]`` that reads the latest
observation through a :class:`View` (the agent updates it after every reply). Bench facts
used here are public (``simhost/track2``): per-step limits, the hand's lead, the mechanism
geometry of the opening family, tool handle sizes. Parameters a controller cannot observe
(peg shape, well depth, …) come from the demonstration's source, passed in ``hints``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

DPOS, DYAW, WMAX = 0.015, 0.15, 0.09
LEAD = np.array([0.02, 0.02, 0.02, 0.3])
LO = np.array([-0.30, -0.30, 0.003, -3.2])
HI = np.array([0.30, 0.30, 0.30, 3.2])
Plan = Iterator[np.ndarray]


def wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def nearest_yaw(yaw: float, period: float, near: float = 0.0) -> float:
    return near + (yaw - near + period / 2) % period - period / 2


def yaw_of(q: np.ndarray) -> float:
    w, x, y, z = (float(v) for v in q)
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def z_axis(q: np.ndarray) -> np.ndarray:
    w, x, y, z = (float(v) for v in q)
    return np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])


def rot2(yaw: float, v: Any) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


class View:
    """The latest observation, and a mirror of the hand's control target.

    The bench moves the target by the action (scaled), keeps it within ``LEAD`` of the hand
    and inside the workspace; mirroring that makes a move land where it is aimed.
    """

    def __init__(self) -> None:
        self.obs: dict[str, np.ndarray] = {}
        self.prev_ee = np.zeros(4)
        self.target = np.zeros(4)

    def update(self, obs: dict[str, Any], *, reset: bool = False) -> None:
        self.prev_ee = self.ee() if self.obs and not reset else np.asarray(obs["proprio"][:4])
        self.obs = {k: np.asarray(v, dtype=float) for k, v in obs.items()
                    if isinstance(v, np.ndarray)}
        if reset:
            self.target = self.ee().copy()

    def ee(self) -> np.ndarray:
        return self.obs["proprio"][:4].copy()

    def speed(self) -> float:
        return float(np.linalg.norm(self.ee()[:2] - self.prev_ee[:2])) * 20.0

    def row(self, i: int) -> np.ndarray:
        return self.obs["parts"][i]

    def pos(self, i: int) -> np.ndarray:
        return self.row(i)[1:4].copy()

    def yaw(self, i: int) -> float:
        return yaw_of(self.row(i)[4:8])

    def joint(self, i: int) -> float:
        return float(self.row(i)[8])

    def present(self, i: int) -> bool:
        return bool(self.row(i)[0] > 0.5)

    def goal(self) -> np.ndarray:
        return self.obs["goal"].copy()

    def command(self, goal: np.ndarray, yaw: float, width: float, speed: float = 1.0) -> np.ndarray:
        goal = np.clip(goal, LO[:3], HI[:3])
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


def pick(v: View, top: np.ndarray, yaw: float, open_w: float, depth: float, lift: float) -> Plan:
    yield from move(v, [top[0], top[1], top[2] + 0.04], yaw, open_w, tol=0.004)
    yield from move(v, [top[0], top[1], top[2] - depth], yaw, open_w, speed=0.6)
    yield from hold(v, 6, 0.0)
    ee = v.ee()
    yield from move(v, [ee[0], ee[1], lift], yaw, 0.0, tol=0.004)


def servo(v: View, error: Callable[[], tuple[np.ndarray, float]], z: float, *,
          tol: float = 0.0006, yaw_tol: float = 0.02, max_steps: int = 40) -> Plan:
    for _ in range(max_steps):
        err, yaw_err = error()
        ee = v.ee()
        if np.linalg.norm(err) < tol and abs(yaw_err) < yaw_tol and v.speed() < 0.003:
            return
        yield from move(v, [ee[0] + err[0], ee[1] + err[1], z], ee[3] + yaw_err, 0.0,
                        max_steps=1)


def release(v: View, open_w: float, up: float) -> Plan:
    yield from hold(v, 6, open_w)
    ee = v.ee()
    yield from move(v, [ee[0], ee[1], ee[2] + up], ee[3], open_w, tol=0.005)


# -- families ---------------------------------------------------------------------------------
def insertion(v: View, hints: dict[str, Any]) -> Plan:
    h = 2 * (v.pos(0)[2] - 0.0005)
    need, depth = float(v.goal()[1]), float(v.goal()[2])
    hole_xy, hole_yaw = v.pos(1)[:2], v.yaw(1)
    peg_yaw = v.yaw(0)
    # Align modulo pi: right for square and rect pegs, harmless for round ones.
    turn = nearest_yaw(hole_yaw - peg_yaw, math.pi)
    yaw0 = nearest_yaw(peg_yaw, math.pi / 2, -turn / 2)
    g = min(0.022, h - depth - 0.006)
    lift = depth + 0.02 + h - g

    def bottom() -> np.ndarray:
        return v.pos(0) - z_axis(v.row(0)[4:8]) * h / 2

    yield from pick(v, v.pos(0) + [0, 0, h / 2], yaw0, WMAX, g, lift)
    for _ in range(3):
        ee = v.ee()
        yield from move(v, [*(ee[:2] + hole_xy - bottom()[:2]), lift], yaw0 + turn, 0.0, tol=0.003)

    def error() -> tuple[np.ndarray, float]:
        return hole_xy - bottom()[:2], wrap(nearest_yaw(hole_yaw - v.yaw(0), math.pi))

    for _ in range(3):
        yield from servo(v, error, lift)
        stuck = 0
        for _ in range(60):
            ee, bot = v.ee(), bottom()
            if bot[2] < 0.004 or depth - bot[2] > need + 0.004:
                break
            xy = ee[:2] + hole_xy - bot[:2] if bot[2] > depth + 0.002 else v.target[:2]
            yield from move(v, [*xy, ee[2] - 0.004], ee[3], 0.0, max_steps=1)
            stuck = stuck + 1 if bottom()[2] > bot[2] - 0.0005 else 0
            if stuck >= 4:
                break
        if bottom()[2] < depth - 0.002:
            break
        ee = v.ee()
        yield from move(v, [*ee[:2], lift], ee[3], 0.0, tol=0.003)
    yield from release(v, WMAX, 0.05)


def rotation(v: View, hints: dict[str, Any]) -> Plan:
    axis, z = v.pos(0)[:2], v.pos(0)[2]
    target = float(v.goal()[1])
    theta = v.joint(0)
    yaw0 = nearest_yaw(theta, math.pi, -(target - theta) / 2)
    tcp_z = z - 0.005
    yield from move(v, [*axis, z + 0.06], yaw0, 0.08, tol=0.004)
    yield from move(v, [*axis, tcp_z], yaw0, 0.08, speed=0.6)
    yield from hold(v, 6, 0.0)
    grip_offset = v.ee()[3] - v.joint(0)

    def angle() -> float:
        # The bench clips part rows to [-2, 2]: past that, follow the hand holding the handle.
        return v.joint(0) if abs(v.joint(0)) < 1.99 else v.ee()[3] - grip_offset

    for _ in range(120):
        err = target - angle()
        if abs(err) < 0.015:
            break
        ee = v.ee()
        yield from move(v, [*axis, tcp_z], ee[3] + float(np.clip(err, -0.1, 0.1)), 0.0,
                        max_steps=1)
    yield from hold(v, 3, 0.0)
    yield from release(v, 0.08, 0.06)


SCALES = (1.0, 0.85, 0.72)


def assembly(v: View, hints: dict[str, Any]) -> Plan:
    n = sum(v.present(i) for i in (1, 2, 3))
    height = 2 * (v.pos(1)[2] - 0.0005)
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
        open_w = min(WMAX, 2 * 0.03 * SCALES[i] + 0.03)
        g = min(0.02, height - 0.012)
        carry = max(i, 1) * height + 0.025 + height - g
        yield from pick(v, v.pos(row) + [0, 0, height / 2], yaw0, open_w, g, carry)
        for _ in range(2):
            ee = v.ee()
            yield from move(v, [*(ee[:2] + offsets()[0]), carry], yaw0 + turn, 0.0, tol=0.003)
        yield from servo(v, lambda offsets=offsets: (offsets()[0], offsets()[2]), carry,
                         tol=0.001, yaw_tol=0.02)
        for _ in range(40):
            dz = offsets()[1]
            if dz < 0.002:
                break
            ee = v.ee()
            yield from move(v, [*ee[:2], ee[2] - min(0.008, max(0.002, dz / 2))], ee[3], 0.0,
                            max_steps=1)
        yield from release(v, open_w, 0.04)


BAR_X, HANDLE_Z, LID_PIVOT, LID_KNOB = -0.045, 0.06, (0.05, 0.05), (-0.09, -0.09)


def opening_kind(v: View) -> str:
    """drawer, sliding_cover or swivel_lid, from where the mover sits on its housing."""
    local = rot2(-v.yaw(1), v.pos(0)[:2] - v.pos(1)[:2])
    if v.pos(0)[2] < 0.025:
        return "drawer"
    return "swivel_lid" if np.linalg.norm(local - LID_PIVOT) < 0.01 else "sliding_cover"


def opening(v: View, hints: dict[str, Any]) -> Plan:
    kind = opening_kind(v)
    origin, frame = v.pos(1)[:2], v.yaw(1)
    goal = v.goal()
    opens = goal[3] > 0

    def grasp(q: float) -> tuple[np.ndarray, float]:
        if kind == "drawer":
            local, z, yaw = (BAR_X - q, 0.0), HANDLE_Z - 0.004, frame + math.pi / 2
        elif kind == "sliding_cover":
            local, z, yaw = (0.0, -0.03 + q), 0.061, frame
        else:
            local, z, yaw = np.array(LID_PIVOT) + rot2(q, LID_KNOB), 0.061, frame + q
        xy = origin + rot2(frame, local)
        return np.array([xy[0], xy[1], z]), yaw

    q0 = v.joint(0)
    pos, yaw = grasp(q0)
    limit_guess = 1.5 if kind == "swivel_lid" else 0.13
    _, yaw_end = grasp(limit_guess if opens else 0.0)
    yaw0 = nearest_yaw(yaw, math.pi, -(yaw_end - yaw) / 2)
    open_w = 0.032 if kind == "drawer" else 0.07
    lim = 0.08 if kind == "swivel_lid" else 0.01
    yield from move(v, pos + [0, 0, 0.05], yaw0, open_w, tol=0.004)
    yield from move(v, pos, yaw0, open_w, speed=0.6)
    yield from hold(v, 6, 0.0)

    def drive(q_goal: float, probe: bool) -> Plan:
        start = best = v.joint(0)
        still = 0
        for _ in range(150):
            q = v.joint(0)
            if probe:  # open until the joint stops: that is its range
                still = still + 1 if q < best + 0.1 * lim else 0
                best = max(best, q)
                if (still >= 4 and best > start + 2 * lim) or still >= 12:
                    hints["range"] = hints["range_measured"] = best
                    return
            elif abs(q_goal - q) < 0.08 * hints["range"] / 3:
                return
            nxt, yaw_n = grasp(q + float(np.clip(q_goal - q, -lim, lim)))
            yield from move(v, nxt, yaw0 + wrap(yaw_n - yaw), 0.0, max_steps=1)

    hints.setdefault("range", limit_guess)
    if opens:
        yield from drive(limit_guess, probe=True)
        yield from drive(float(goal[1]) * hints["range"], probe=False)
    else:
        yield from drive(0.0, probe=False)
    yield from hold(v, 3, 0.0)
    yield from release(v, open_w, 0.06)


def pick_tool(v: View) -> tuple[int, float]:
    """The slot of the longer tool (the short one is a distractor) and its length."""
    press = v.goal()[0] < 0.5
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
    press = v.goal()[0] < 0.5
    slot, _ = pick_tool(v)
    tool, tip = 2 * slot, 2 * slot + 1
    tool_yaw = v.yaw(tool)
    top = v.pos(tool) + z_axis(v.row(tool)[4:8]) * (0.015 if press else 0.03)
    if press:
        yaw0 = nearest_yaw(tool_yaw, math.pi / 2)
        depth = 0.054
        yield from pick(v, top, yaw0, 0.045, depth, top[2] - depth + 0.075)
        well = float(hints.get("well_depth", 0.08)) + 0.01
        target = v.pos(4)[:2]
        z = well + 0.02 + (v.ee()[2] - v.pos(tip)[2])
        for _ in range(3):
            ee = v.ee()
            yield from move(v, [*(ee[:2] + target - v.pos(tip)[:2]), z], ee[3], 0.0, tol=0.003)
        yield from servo(v, lambda: (target - v.pos(tip)[:2], 0.0), z, tol=0.0015)
        for _ in range(80):
            if v.joint(4) <= -0.0065:
                break
            ee = v.ee()
            step = 0.006 if v.pos(tip)[2] > well else 0.003
            yield from move(v, [*(ee[:2] + target - v.pos(tip)[:2]), ee[2] - step], ee[3], 0.0,
                            max_steps=1)
        yield from hold(v, 5, 0.0)
        return
    turn = wrap(0.0 - tool_yaw)
    yaw0 = nearest_yaw(tool_yaw, math.pi, -turn / 2)
    yield from pick(v, top, yaw0, 0.045, min(0.054, top[2] - 0.004), 0.08)
    ee = v.ee()
    yield from move(v, [*ee[:2], 0.08], yaw0 + turn, 0.0, tol=0.004, speed=0.7)
    puck, goal_x = v.pos(4), float(v.goal()[1])
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
