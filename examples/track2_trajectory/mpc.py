"""The demonstration's trajectory adapted by planning through the learned world model.

Each phase the demo parser finds in the demonstration (``parse.py``: which row the hand
held, the grasp in that row's frame, where the row ended relative to a reference row) is a
goal configuration of the parts; the hand's next displacement is chosen by
``worldmodel.plan_step`` so that the part, as the model predicts it, moves there:

- ``carry``: grasp as the demonstration did, lift, then plan the hand's motion so the held
  part's predicted pose reaches its goal relative to the reference row, lower, let go;
- ``drive``: the part's path from where it starts to its goal (``generic.Motion``: a slide,
  or a turn about the pivot start and goal imply), planned a lead ahead along that path
  with the hand kept at the grasp on the predicted part;
- ``tool``: the demo parser's tool phase (the tip's path relative to the part it acts on).

Receding horizon: after a carry or a drive the plan starts again from the parts as they
now are while the part is off its goal configuration (up to ``REPLANS`` per attempt).

Online adaptation between attempts (``Memory``, kept by the agent across the episode's
attempts): what the attempt's transitions showed about this instance changes the next
attempt's plan. A drive whose part did not follow the hand at all (the model predicted
motion, the instance showed none: the path is blocked) is planned next time along the
demonstration's path reflected across the reference row's axis (a turn the other way, a
cover or lid mirrored: the other trajectory the same fixture admits); a carry that came
to rest off its goal aims the next time where it should land, less that miss. What it does
not have is a task model: no stage or success condition of its own, no measured joint
range, no reading of the instance's mechanism.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import replace
from typing import Any

import numpy as np
from controllers import Plan, View, hold, look, move, release
from generic import _grasp_pose, _lower, approach, near_period, path_of, pick_up, pose, tool
from parse import DemoParse, Phase, compose, relative
from perception import wrap
from worldmodel import PartDynamics, plan_step

REPLANS = 3  # plans per phase and attempt
BLOCKED = 0.08  # a drive whose part went less than this fraction of its path was blocked
MISS_MAX = 0.015  # m: a carry's miss larger than this is not a bias but a failed placement
HORIZON = 3  # steps a drive's planner looks ahead (a carry's looks one step: a servo)
TURN_PERIOD = math.pi  # the two-finger hand grips alike at yaw and yaw + pi


class Memory(dict[int, dict[str, Any]]):
    """What earlier attempts showed, per phase index: ``mirrored`` (plan the reflected
    path), ``miss`` (a carry's resting error, xy in the reference row's frame)."""

    def of(self, i: int) -> dict[str, Any]:
        return self.setdefault(i, {})


def mirrored(ph: Phase) -> Phase:
    """The phase reflected across its reference row's x axis (a pose (x, y, z, yaw) in that
    frame becomes (x, -y, z, -yaw)): its goal, its start and its grasp; a drive's own
    displacement, in the part's frame, turns the other way."""
    def m(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else np.array([a[0], -a[1], a[2], -a[3]])
    return replace(ph, goal=m(ph.goal), start_rel=m(ph.start_rel), grasp=m(ph.grasp),
                   displacement=m(ph.displacement))


def push(v: View, d: np.ndarray, z: float) -> Plan:
    """The hand's planned displacement ``d`` (dx, dy, -, dyaw), one step, fingers closed,
    at height ``z``. The model maps the hand's motion to the part's; the hand is servoed to
    a control target, which runs ahead of it while a joint's friction resists. So ``d``'s
    xy is added to that target, not to where the hand is: the lead that makes the force
    stays. Its yaw is added to the wrist's yaw as it is: a wrist wound up against a stop
    would force the part through it."""
    t, hand = v.target, v.ee()
    yield from move(v, [t[0] + d[0], t[1] + d[1], z], hand[3] + d[3], 0.0, max_steps=1)


def _goal(v: View, ph: Phase) -> np.ndarray:
    assert ph.ref is not None and ph.goal is not None
    return compose(pose(v, ph.ref), ph.goal)


def _error(v: View, ph: Phase) -> tuple[np.ndarray, float]:
    """How far the held part is from its goal: xy (m) and yaw (rad, modulo a half turn)."""
    g, p = _goal(v, ph), pose(v, ph.held)
    return g[:2] - p[:2], float(wrap(near_period(g[3] - p[3], TURN_PERIOD)))


def carry(v: View, ph: Phase, model: PartDynamics, kind: str, mem: dict[str, Any]) -> Plan:
    """Carry the held row to its goal relative to the reference row, replanned from the
    parts as they are while it rests off that goal; aimed short of the goal by the miss
    earlier attempts measured (``mem["miss"]``), and the miss of this one kept."""
    held, true = ph.held, ph
    assert ph.goal is not None
    miss = np.asarray(mem.get("miss", np.zeros(2)))
    ph = replace(ph, goal=ph.goal - np.array([miss[0], miss[1], 0.0, 0.0]))
    rng = np.random.default_rng(held)
    for _ in range(REPLANS):
        lift = yield from pick_up(v, ph)
        # the transport: straight over the goal (the demonstration's path carries the part
        # at its height), then the placement planned through the model, one step ahead
        for _ in range(3):
            err, dyaw = _error(v, ph)
            ee = v.ee()
            yield from move(v, [*(ee[:2] + err), lift], ee[3] + dyaw, 0.0, tol=0.003)
        yield from look(v, 4)
        for _ in range(40):
            part, hand = pose(v, held), v.ee()
            err, dyaw = _error(v, ph)
            if np.linalg.norm(err) < 0.001 and abs(dyaw) < 0.02 and v.speed() < 0.003:
                break
            target = np.array([part[0] + err[0], part[1] + err[1], part[2], part[3] + dyaw])
            guess = np.array([err[0], err[1], 0.0, dyaw])
            d = plan_step(model, kind, part, hand, target, None, guess, horizon=1, rng=rng)
            yield from push(v, d, lift)
        drop = v.pos(held)[2] - _goal(v, ph)[2]
        yield from _lower(v, held, drop + 0.02)
        yield from hold(v, 2, 0.0)
        yield from release(v, max(ph.open_width, 0.03), 0.04)
        yield from look(v, 8)
        g, p = _goal(v, true), pose(v, held)
        if p[2] < g[2] + 0.004:  # down on its support: how far off, in the reference's frame
            assert true.ref is not None and true.goal is not None
            off = relative(p, pose(v, true.ref))[:2] - true.goal[:2]
            if np.linalg.norm(off) < MISS_MAX:
                mem["miss"] = miss + off
        if np.linalg.norm(g[:2] - p[:2]) < 0.004 and p[2] < g[2] + 0.004:
            return


def drive(v: View, ph: Phase, model: PartDynamics, kind: str, state_goal: bool,
          mem: dict[str, Any]) -> Plan:
    """Move the held mechanism along its path to the goal, replanned from where it stopped
    while it is short of the goal; the reflected path when an earlier attempt found this
    one blocked (``mem["mirrored"]``, which this attempt updates)."""
    if mem.get("mirrored"):
        ph = mirrored(ph)
    held = ph.held
    rng = np.random.default_rng(held)
    motion = path_of(v, ph, state_goal)  # from where the part is: progress 0
    step = 0.01 / max(motion.length, 0.01)  # about 1 cm (or 0.1 rad) per step
    for _ in range(REPLANS):
        s0 = motion.progress(pose(v, held))
        if abs(1 - s0) * motion.length < 0.003:
            return
        part = motion.at(s0)
        at, yaw0 = _grasp_pose(v, ph, part, (1 - s0) * motion.dyaw)
        k_yaw = yaw0 - (part[3] + ph.grasp[3])  # the grasp's multiple of pi
        grasp = ph.grasp.copy()
        grasp[3] += k_yaw
        yield from approach(v, at, yaw0, max(ph.open_width, 0.03), ph.held_width)
        stuck, best = 0, s0
        for _ in range(200):
            now = pose(v, held)
            s = motion.progress(now)
            if abs(1 - s) * motion.length < 0.002:
                break
            stuck = stuck + 1 if s < best + 0.1 * step else 0
            best = max(best, s)
            if stuck > 12:
                break
            # a lead per step of the horizon, more while the part lags (friction)
            lead = HORIZON * step * min(2.5, 1.0 + 0.3 * stuck)
            target = motion.at(s + float(np.clip(1 - s, -lead, lead)))
            hand = v.ee()
            if motion.pivot is None:
                # a slide: only the progress along the path is asked of the part, along
                # the way the model says it moves (its own axis). The line from its
                # measured start to its goal is off that axis by the measurement errors:
                # a target on the line would stall the plan short of the goal.
                u = motion.goal[:2] - motion.start[:2]
                u = u / max(float(np.linalg.norm(u)), 1e-9)
                moved = model.step(kind, now, np.array([*(0.01 * u), 0.0, 0.0]), 1.0,
                                   hand[:2])[:2] - now[:2]
                if float(moved @ u) > 0.002:
                    target[:2] = now[:2] + float((target[:2] - now[:2]) @ u) / float(
                        moved @ u) * moved
            want = compose(target, grasp)
            guess = np.array([want[0] - hand[0], want[1] - hand[1], 0.0,
                              wrap(want[3] - hand[3])])
            now[3] = target[3] - wrap(target[3] - now[3])  # unwrapped next to the path
            d = plan_step(model, kind, now, hand, target, grasp, guess / HORIZON,
                          horizon=HORIZON, rng=rng)
            yield from push(v, d, want[2])
        yield from hold(v, 3, 0.0)
        yield from release(v, max(ph.open_width, 0.03), 0.05)
        yield from look(v, 8)
        if motion.progress(pose(v, held)) < BLOCKED:
            # the model predicted the part would follow the hand; at rest, let go and seen
            # unhidden, it has not moved: blocked this way (while held, its measurement
            # followed the slipping fingers). The next attempt plans the other path the
            # fixture admits.
            mem["mirrored"] = not mem.get("mirrored", False)
            return


def execute(v: View, dp: DemoParse, model: PartDynamics, kinds: dict[int, str],
            state_goal: bool, memory: Memory) -> Iterator[np.ndarray]:
    """Every phase of the demonstration, in order, planned through ``model``
    (``kinds``: the kind of part of each row the hand holds), adapted by what earlier
    attempts showed (``memory``, updated by this one)."""
    yield from look(v, 8)
    for i, ph in enumerate(dp.phases):
        kind = kinds.get(ph.held, "free")
        if ph.kind == "carry":
            yield from carry(v, ph, model, kind, memory.of(i))
        elif ph.kind == "drive":
            yield from drive(v, ph, model, kind, state_goal, memory.of(i))
        else:
            yield from tool(v, ph, dp)
