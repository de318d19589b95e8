"""Generic scripted controllers, parameterised by the parsed demonstration (``parse.py``).

Nothing here knows a task family or the bench's geometry: every controller reads the phase
the demonstration showed — which row the hand held, the hand's pose in that row's frame
when the fingers closed, where the row ended relative to another row, the path a tool's tip
took relative to the part it acted on — and the instance's own observations (through
``controllers.View``: filtered part poses, the exact proprioception, the force summary).

- ``carry`` (a part lifted and let go elsewhere): grasp it as the demonstration did, carry it
  above where it ended relative to its reference row, servo the held part onto that pose
  (x, y, yaw), lower until the contact stops it, let go, look. ``checked`` adds the task
  model's success condition (not the demo parser's): a descent stopped above the goal is
  searched around, and while the part rests too far from the goal it is grasped again and
  the carry retried with the descent moved around the first point (a spiral: what failed
  was the alignment).
- ``drive`` (a mechanism moved with the hand, never lifted): the part's motion is a planar
  rigid motion (a slide or a turn about a pivot) from where it starts to its goal — the
  demonstration's end pose relative to the reference row when the annotation stated a
  value (a state: opened to a fraction), the demonstration's displacement of the part from
  its own start otherwise (a motion: the same turn). The hand follows that motion at the
  grasp, closed on the observed progress; with ``tries`` > 1 (a success condition checked:
  the task model's, not the demo parser's) it regrasps while the part is short of the goal.
- ``tool`` (a part lifted and held to the end): grasp it, follow its tip's path relative to
  the part it acted on, then push on along the path's last direction while the part the
  tool moved is short of where the demonstration left it relative to its reference.

A controller that is through leaves the rest of the attempt to the agent (it ends it).
"""

from __future__ import annotations

import math
from collections.abc import Generator, Iterator
from typing import Any

import numpy as np
from controllers import WMAX, Plan, View, grip, hold, look, move, release, servo
from parse import DemoParse, Phase, compose
from perception import rot2, wrap

TURN_PERIOD = math.pi  # the two-finger hand grips alike at yaw and yaw + pi


def pose(v: View, i: int) -> np.ndarray:
    return np.array([*v.pos(i), v.yaw(i)])


def near_period(a: float, period: float, near: float = 0.0) -> float:
    return near + (a - near + period / 2) % period - period / 2


def spiral(spacing: float, rings: int) -> list[np.ndarray]:
    out = []
    for k in range(1, rings + 1):
        for j in range(6 * k):
            a = 2 * math.pi * j / (6 * k) + 0.5 * k
            out.append(k * spacing * np.array([math.cos(a), math.sin(a)]))
    return out


def _grasp_pose(v: View, ph: Phase, part: np.ndarray, turn: float) -> tuple[np.ndarray, float]:
    """The hand's pose for the demonstration's grasp on ``part``, its yaw chosen (modulo pi)
    so that a later turn by ``turn`` stays within the wrist's range."""
    hand = compose(part, ph.grasp)
    yaw = near_period(float(hand[3]), TURN_PERIOD, -turn / 2)
    return np.array([hand[0], hand[1], max(hand[2], 0.006)]), yaw


def holding(v: View, width: float = 0.0) -> bool:
    """Both fingers in contact, apart by at least half the width the demonstration held
    (else they closed on nothing or on an edge); the exact proprioception."""
    prop = v.obs["proprio"]
    return bool(prop[5] > 0.5 and prop[6] > 0.5 and prop[4] > max(0.004, 0.5 * width))


def approach(v: View, at: np.ndarray, yaw: float, open_w: float, width: float = 0.0) -> Plan:
    """Down onto ``at`` with the fingers open, close; a descent that stops above ``at`` (a
    finger on the part) or a grasp that closes on nothing (the pose estimate is off by more
    than the fingers' slack) is tried again around ``at``."""
    offsets = [np.zeros(2), *spiral(0.005, 2)][:8]
    for j, off in enumerate(offsets):
        p = np.array([at[0] + off[0], at[1] + off[1], at[2]])
        yield from move(v, [p[0], p[1], p[2] + 0.045], yaw, open_w, tol=0.004)
        stuck = 0
        for _ in range(40):
            ee = v.ee()
            if ee[2] < p[2] + 0.002 or stuck >= 3:
                break
            yield from move(v, [p[0], p[1], max(p[2], ee[2] - 0.009)], yaw, open_w,
                            max_steps=1)
            stuck = stuck + 1 if v.ee()[2] > ee[2] - 0.001 else 0
        if v.ee()[2] > p[2] + 0.003 and j + 1 < len(offsets):  # stopped on top: elsewhere
            ee = v.ee()
            yield from move(v, [ee[0], ee[1], p[2] + 0.045], yaw, open_w, tol=0.004)
            continue
        yield from grip(v, 0.0, 6)
        if holding(v, width):
            return
        yield from grip(v, open_w, 2)
        ee = v.ee()
        yield from move(v, [ee[0], ee[1], p[2] + 0.045], yaw, open_w, tol=0.004)


def _lower(v: View, part: int, floor: float, xy: Any = None) -> Plan:
    """Lower the held part until it stops (its support or a floor) or ``floor`` m below."""
    stuck = 0
    start = v.ee()[2]
    for _ in range(60):
        ee = v.ee()
        if stuck >= 4 or ee[2] < start - floor:
            return
        goal_xy = v.target[:2] if xy is None else xy
        yield from move(v, [*goal_xy, ee[2] - 0.004], ee[3], 0.0, max_steps=1)
        stuck = stuck + 1 if v.ee()[2] > ee[2] - 0.0005 else 0


def _fresh(v: View, i: int, steps: int = 12) -> Plan:
    """Hold still until a held row has been measured in the hand a few times."""
    n0 = v.p.settled(i)
    for _ in range(steps):
        if v.p.settled(i) >= n0 + 2:
            return
        yield from hold(v, 1, 0.0)


# -- carry ------------------------------------------------------------------------------------
def pick_up(v: View, ph: Phase) -> Generator[np.ndarray, None, float]:
    """A carry's start: grasp the held row as the demonstration did (its yaw chosen so the
    turn to the goal stays within the wrist's range), lift it clear above its goal relative
    to the reference row, hold still until it is measured in the hand. Returns the lift's
    height (the hand's z)."""
    assert ph.ref is not None and ph.goal is not None
    goal = compose(pose(v, ph.ref), ph.goal)
    part = pose(v, ph.held)
    turn = wrap(near_period(goal[3] - part[3], TURN_PERIOD))
    at, yaw0 = _grasp_pose(v, ph, part, turn)
    yield from approach(v, at, yaw0, max(ph.open_width, 0.03), ph.held_width)
    lift = max(ph.carry_z, goal[2] + (v.ee()[2] - part[2]) + 0.03)
    ee = v.ee()
    yield from move(v, [ee[0], ee[1], lift], yaw0, 0.0, tol=0.004)
    yield from _fresh(v, ph.held)
    return float(lift)


def carry(v: View, ph: Phase, checked: bool) -> Plan:
    """One carry; ``checked``: its success condition (the part where the demonstration left
    it, down on its support) is checked, a rim searched and the carry redone (up to 3)."""
    assert ph.ref is not None and ph.goal is not None
    held, ref = ph.held, ph.ref
    offsets = [np.zeros(2), *spiral(0.002, 2)]
    for k in range(3 if checked else 1):
        lift = yield from pick_up(v, ph)

        def error(off: np.ndarray = offsets[k % len(offsets)]) -> tuple[np.ndarray, float]:
            g = compose(pose(v, ref), ph.goal)
            p = pose(v, held)
            return g[:2] + off - p[:2], wrap(near_period(g[3] - p[3], TURN_PERIOD))

        for _ in range(3):
            err, dyaw = error()
            ee = v.ee()
            yield from move(v, [*(ee[:2] + err), lift], ee[3] + dyaw, 0.0, tol=0.003)
        yield from look(v, 4)
        yield from servo(v, error, lift, tol=0.001, yaw_tol=0.02)
        drop = v.pos(held)[2] - compose(pose(v, ref), ph.goal)[2]
        yield from _lower(v, held, drop + 0.02)
        high = v.pos(held)[2] - compose(pose(v, ref), ph.goal)[2]
        if checked and high > 0.004:  # stopped above the goal: on a rim; search around
            centre, base = v.ee()[:2].copy(), v.ee()[2]
            for off in spiral(0.0025, 2):
                yield from move(v, [*(centre + off), base + 0.006], v.ee()[3], 0.0,
                                tol=0.0015, max_steps=5)
                yield from _lower(v, held, high + 0.01, centre + off)
                if v.pos(held)[2] - compose(pose(v, ref), ph.goal)[2] < 0.003:
                    break
        yield from hold(v, 2, 0.0)
        yield from release(v, max(ph.open_width, 0.03), 0.04)
        yield from look(v, 8)
        g, p = compose(pose(v, ref), ph.goal), pose(v, held)
        if np.linalg.norm(g[:2] - p[:2]) < 0.004 and p[2] < g[2] + 0.004:
            return


# -- drive ------------------------------------------------------------------------------------
class Motion:
    """A planar rigid motion of a part from ``start`` to ``goal`` (x, y, z, yaw): a turn about
    a pivot when the yaw changes, else a slide; ``at(s)`` for s in [0, 1]."""

    def __init__(self, start: np.ndarray, goal: np.ndarray) -> None:
        self.start, self.goal = start.copy(), goal.copy()
        self.dyaw = float(goal[3] - start[3])
        d = goal[:2] - start[:2]
        self.pivot: np.ndarray | None = None
        if abs(self.dyaw) > 0.08:
            # the fixed point c of: c + R(dyaw)(start - c) = goal
            r = np.array([[math.cos(self.dyaw), -math.sin(self.dyaw)],
                          [math.sin(self.dyaw), math.cos(self.dyaw)]])
            a = np.eye(2) - r
            self.pivot = np.linalg.solve(a, goal[:2] - r @ start[:2])
            if np.linalg.norm(self.pivot - start[:2]) > 0.3:
                self.pivot = None
        self.length = float(np.linalg.norm(d)) + 0.1 * abs(self.dyaw)

    def at(self, s: float, extrapolate: bool = False) -> np.ndarray:
        if not extrapolate:
            s = float(np.clip(s, 0.0, 1.0))
        if self.pivot is None:
            p = self.start + s * (self.goal - self.start)
            return np.array([*p[:3], self.start[3] + s * self.dyaw])
        xy = self.pivot + rot2(s * self.dyaw, self.start[:2] - self.pivot)
        z = self.start[2] + s * (self.goal[2] - self.start[2])
        return np.array([xy[0], xy[1], z, self.start[3] + s * self.dyaw])

    def progress(self, p: np.ndarray) -> float:
        """Where along the motion the observed pose ``p`` is."""
        if self.pivot is None:
            d = self.goal[:2] - self.start[:2]
            n = float(d @ d)
            return float((p[:2] - self.start[:2]) @ d / n) if n > 1e-9 else 1.0
        turned = self.start[3] + wrap(p[3] - self.start[3] - self.dyaw / 2) + self.dyaw / 2
        return float((turned - self.start[3]) / self.dyaw)


def path_of(v: View, ph: Phase, state_goal: bool) -> Motion:
    """A drive's motion of its part, from where the part is now: to the demonstration's end
    pose relative to the reference row when the goal is a state (``state_goal``), else by
    the demonstration's displacement of the part from its own start."""
    assert ph.displacement is not None
    start = pose(v, ph.held)
    if state_goal and ph.ref is not None and ph.goal is not None:
        goal = compose(pose(v, ph.ref), ph.goal)
        goal[3] = start[3] + wrap(goal[3] - start[3])
    else:
        goal = compose(start, ph.displacement)
    return Motion(start, goal)


def drive(v: View, ph: Phase, state_goal: bool, tries: int, stall: float = 0.0) -> Any:
    """Follow the part's motion at the grasp (see the module docstring); with ``stall`` > 0,
    give up when the part has not followed by that fraction after 10 steps. Returns how far
    the part and the hand went along the motion (fractions of it) on the last try."""
    held = ph.held
    motion = path_of(v, ph, state_goal)
    step = 0.01 / max(motion.length, 0.01)  # about 1 cm (or 0.1 rad) per step
    went = (0.0, 0.0)
    for _ in range(tries):
        s0 = motion.progress(pose(v, held))
        if abs(1 - s0) * motion.length < 0.003:
            return went
        part = motion.at(s0)
        at, yaw0 = _grasp_pose(v, ph, part, (1 - s0) * motion.dyaw)
        k_yaw = yaw0 - (part[3] + ph.grasp[3])  # the grasp's multiple of pi
        yield from approach(v, at, yaw0, max(ph.open_width, 0.03), ph.held_width)
        hand0 = v.ee()
        stuck, best = 0, s0
        for _ in range(200):
            s = motion.progress(pose(v, held))
            if abs(1 - s) * motion.length < 0.002:
                break
            stuck = stuck + 1 if s < best + 0.1 * step else 0
            best = max(best, s)
            if stuck > 12 or (stall and stuck > 10 and best - s0 < stall):
                break
            # lead the part by a step, more while it lags (the joint's friction needs force)
            lead = step * min(2.5, 1.0 + 0.3 * stuck)
            nxt = compose(motion.at(s + float(np.clip(1 - s, -lead, lead))), ph.grasp)
            yield from move(v, nxt[:3], float(nxt[3] + k_yaw), 0.0, max_steps=1)
        hand = v.ee()
        travel = float(np.linalg.norm(hand[:2] - hand0[:2])) + 0.1 * abs(wrap(hand[3] - hand0[3]))
        went = (best - s0, travel / max(motion.length, 1e-6))
        yield from hold(v, 3, 0.0)
        yield from release(v, max(ph.open_width, 0.03), 0.05)
        yield from look(v, 8)
        if stall and best - s0 < stall:
            return went
    return went


# -- tool -------------------------------------------------------------------------------------
def tool(v: View, ph: Phase, dp: DemoParse) -> Plan:
    tip = ph.tip if ph.tip is not None else ph.held
    anchor = ph.anchor if ph.anchor is not None else ph.ref
    assert anchor is not None
    part = pose(v, ph.held)
    turn = wrap(float(ph.path[0][3]) - (part[3] + ph.grasp[3])) if ph.path else 0.0
    at, yaw0 = _grasp_pose(v, ph, part, turn)
    k_yaw = yaw0 - (part[3] + ph.grasp[3])  # the grasp's multiple of pi: path yaws follow it
    yield from approach(v, at, yaw0, max(ph.open_width, 0.03), ph.held_width)
    ee = v.ee()
    yield from move(v, [ee[0], ee[1], max(ph.carry_z, 0.08)], ee[3], 0.0, tol=0.004)
    origin = v.pos(anchor).copy()
    path = ph.path[::3] + ph.path[-1:]
    if not path:
        return
    for wp in path:
        want = origin + wp[:3]
        for _ in range(6):
            ee, tp = v.ee(), v.pos(tip)
            err = want - tp
            yield from move(v, ee[:3] + err, wrap(float(wp[3] + k_yaw)), 0.0, max_steps=1)
            if np.linalg.norm(want - v.pos(tip)) < 0.004:
                break
    yield from look(v, 4)
    if ph.moved is not None and ph.moved_ref is not None and ph.moved_goal is not None \
            and ph.moved_dir is not None:
        u = ph.moved_dir
        for _ in range(120):  # push on while the moved part is short of its goal
            goal = v.pos(ph.moved_ref) + ph.moved_goal
            short = float((goal[:2] - v.pos(ph.moved)[:2]) @ u)
            if short < 0.003:
                break
            ee = v.ee()
            d = min(0.006, short)
            yield from move(v, [ee[0] + d * u[0], ee[1] + d * u[1], ee[2]], ee[3], 0.0,
                            max_steps=1)
    else:  # push on along the path's last direction until the part stops the tool
        if len(ph.path) >= 2:
            d = ph.path[-1][:3] - ph.path[max(0, len(ph.path) - 4)][:3]
            n = float(np.linalg.norm(d))
            if n > 1e-4:
                d = d / n
                stuck = 0
                for _ in range(40):
                    ee = v.ee()
                    yield from move(v, ee[:3] + 0.004 * d, ee[3], 0.0, max_steps=1)
                    stuck = stuck + 1 if np.linalg.norm(v.ee()[:3] - ee[:3]) < 0.0005 else 0
                    if stuck >= 4:
                        break
    yield from hold(v, 5, 0.0)


def execute(v: View, dp: DemoParse, state_goal: bool) -> Iterator[np.ndarray]:
    """Every phase of the demonstration, in order, on the instance."""
    yield from look(v, 8)
    for ph in dp.phases:
        if ph.kind == "carry":
            yield from carry(v, ph, checked=False)
        elif ph.kind == "drive":
            yield from drive(v, ph, state_goal, tries=1)
        else:
            yield from tool(v, ph, dp)


__all__ = ["execute", "Motion", "WMAX"]
