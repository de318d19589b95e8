"""Closed-loop skills of the task-model baseline: act, predict, compare, adapt.

Every skill is a generator of actions on a ``controllers.View`` (the demo parser's
perception and primitives, which this image inherits) and reads the explicit task model
(``model``: goal relations from the demonstration, constraints measured on this instance).
Where the demo parser executes a stage and moves on, a skill here

- predicts what its motion should do to the part (a turn, a slide, a descent) and compares
  with what the proprioception and the observations say: a part that does not follow is
  blocked (a one-way stop, a mirrored mechanism, a rim), and the skill adapts (the other
  way, a search around the rim) and records what it learned in ``model``;
- checks the success conditions after acting (the turn, the fraction, a part seated) and
  corrects while they do not hold.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
from controllers import Plan, View, grip, hold, look, move, nearest_yaw, release, servo
from generic import Motion, approach, carry, drive, near_period, pose, tool
from parse import DemoParse, Phase, compose, relative


# -- insertion, assembly: each demonstrated carry, placed relative to its reference, checked ---
def insertion(v: View, model: dict[str, Any], dp: DemoParse) -> Plan:
    yield from look(v, 8)
    for ph in dp.phases:
        if ph.kind == "carry":
            yield from carry(v, ph, checked=True)


assembly = insertion


# -- rotation: turn, notice a blocked direction, check the turn after letting go ---------------
def rotation(v: View, model: dict[str, Any], dp: DemoParse) -> Plan:
    """The demonstration's turn from where the handle starts; a handle that does not follow
    the predicted turn is against a stop: the other way (kept for later attempts)."""
    yield from look(v, 8)
    ph = next((p for p in dp.phases if p.kind == "drive"), None)
    if ph is None or ph.displacement is None:
        return
    turn = float(model.get("turn", ph.displacement[3]))
    for _ in range(2):
        disp = ph.displacement.copy()
        disp[3] = turn
        part, _ = yield from drive(v, replace(ph, displacement=disp), False, tries=2,
                                      stall=0.08)
        if part >= 0.08 or model.get("direction_flipped"):
            return
        # predicted to turn; the handle did not, whether the hand held still or slipped
        # round it under growing force: a stop
        model["turn"] = turn = -turn
        model["direction_flipped"] = True


# -- opening: the demonstrated motion, its ends measured, the stated fraction, checked ---------
def _mirror(rel: np.ndarray) -> np.ndarray:
    """A pose in the reference row's frame, reflected across that frame's x axis."""
    return np.array([rel[0], -rel[1], rel[2], -rel[3]])


def opening(v: View, model: dict[str, Any], dp: DemoParse) -> Plan:
    """The mechanism's motion is the demonstration's (a slide, or a turn about a pivot, in the
    housing's frame; +s is the demonstration's way, toward the goal); its ends are measured
    by driving to each stop, back then forward (kept for later attempts); the goal is the
    stated fraction between them. A mechanism that does not move forward is taken to be
    mirrored; a slide that went farther back than forward runs the other way round."""
    ph = next((p for p in dp.phases if p.kind == "drive"), None)
    yield from look(v, 10)
    if ph is None or ph.ref is None or ph.goal is None or ph.start_rel is None:
        return
    mover, housing = ph.held, ph.ref
    opens = model.get("mode", "open") == "open"
    frac = float(model.get("fraction", 0.8 if opens else 0.2))

    def setup() -> tuple[Motion, np.ndarray]:
        mir = bool(model.get("mirrored", False))
        a, b, g = ph.start_rel, ph.goal, ph.grasp
        if mir:
            a, b, g = _mirror(a), _mirror(b), _mirror(g)
        return Motion(a, b), g

    def s_now(motion: Motion) -> float:
        return motion.progress(relative(pose(v, mover), pose(v, housing)))

    def drive_to(motion: Motion, grasp: np.ndarray, k_yaw: float, s_goal: float,
                 probe: bool) -> Any:
        """Drive towards ``s_goal``; returns (s reached, moved at all)."""
        cm = 0.01 / max(motion.length, 0.01)  # 1 cm (or 0.1 rad) of the motion, in s
        lead = (2.0 if probe else 1.0) * cm  # a probe leads the part by more: quicker
        s0 = best = s_now(motion)
        stuck = 0
        for _ in range(160):
            s = s_now(motion)
            if not probe and abs(s_goal - s) * motion.length < 0.0015:
                break
            ahead = (s - best) * np.sign(s_goal - s0) if s_goal != s0 else 0.0
            stuck = stuck + 1 if ahead < 0.1 * cm else 0
            if ahead > 0:
                best = s
            if stuck >= (5 if probe else 8):
                break
            nxt = motion.at(s + float(np.clip(s_goal - s, -lead, lead)), extrapolate=True)
            hand = compose(compose(pose(v, housing), nxt), grasp)
            yield from move(v, hand[:3], float(hand[3] + k_yaw), 0.0, max_steps=1)
        s = s_now(motion)
        return s, abs(s - s0) * motion.length > 0.01

    for _ in range(3):
        motion, grasp = setup()
        s0 = s_now(motion)
        mov = compose(pose(v, housing), motion.at(s0, extrapolate=True))
        hand = compose(mov, grasp)
        yaw0 = near_period(float(hand[3]), math.pi, 0.0)
        k_yaw = yaw0 - float(hand[3])
        open_w = max(ph.open_width, 0.03)
        yield from approach(v, hand[:3], yaw0, open_w, ph.held_width)
        if "ends" not in model:
            # Measure the ends: first the one the demonstration started near (against its
            # motion: a short way, the instance starts near there too), then the other, so
            # that the drive ends at the stop nearer the goal.
            far = 3.0 / max(motion.length, 0.01)  # past any stop: 3 m (or 30 rad) away
            s_back, _ = yield from drive_to(motion, grasp, k_yaw, s0 - far, True)
            s_fwd, moved = yield from drive_to(motion, grasp, k_yaw, s_back + far, True)
            # Predicted: a short way back, the whole range forward. A part that does not
            # move forward, or went farther back than forward, moves the other way round.
            flipped = not moved or abs(s0 - s_back) > 0.5 * abs(s_fwd - s_back)
            if flipped and moved and motion.pivot is None:
                # a slide along the same line the other way round: the ends as measured
                s_back, s_fwd = s_fwd, s_back
            elif flipped and not model.get("mirror_tried"):
                model["mirror_tried"] = True
                model["mirrored"] = not model.get("mirrored", False)
                yield from release(v, open_w, 0.05)
                continue
            s_open, s_closed = (s_fwd, s_back) if opens else (s_back, s_fwd)
            model["ends"] = (s_closed, s_open)
            unit = abs(motion.dyaw) if motion.pivot is not None else float(
                np.linalg.norm(motion.goal[:2] - motion.start[:2]))
            model["range"] = abs(s_open - s_closed) * unit  # m, or rad for a turn
        s_closed, s_open = model["ends"]
        goal = s_closed + frac * (s_open - s_closed)
        yield from drive_to(motion, grasp, k_yaw, goal, False)
        yield from hold(v, 3, 0.0)
        yield from release(v, open_w, 0.06)
        yield from look(v, 10)
        if abs(s_now(motion) - goal) < 0.025 * abs(s_open - s_closed):
            break


# -- tool use: the mechanism this instance has, then press or pull, checked ---------------------
def _grasp_from_above(v: View, row: int) -> Plan:
    """Grasp an unknown tool at its handle row: down from above, fingers open, until the palm
    meets it (the force summary) or the hand stops, then close."""
    p, yaw = v.pos(row), nearest_yaw(v.yaw(row), math.pi)
    yield from move(v, [p[0], p[1], p[2] + 0.08], yaw, 0.045, tol=0.004)
    stuck = 0
    for _ in range(40):
        ee = v.ee()
        if v.obs["force"][2] > 0.5 or stuck >= 3:
            break
        yield from move(v, [p[0], p[1], ee[2] - 0.006], yaw, 0.045, max_steps=1)
        stuck = stuck + 1 if v.ee()[2] > ee[2] - 0.001 else 0
    ee = v.ee()
    yield from move(v, [ee[0], ee[1], ee[2] + 0.004], yaw, 0.045, max_steps=3)
    yield from grip(v, 0.0, 6)


def tool_use(v: View, model: dict[str, Any], dp: DemoParse) -> Plan:
    yield from look(v, 8)
    press = bool(v.pos(4)[0] < 0.3)  # a target within the hand's reach sits in a well
    model["mechanism"] = "press" if press else "pull"
    ph = next((p for p in dp.phases if p.kind == "tool"), None)
    model.setdefault("rest", float(v.pos(4)[2]))
    same = ph is not None and (model.get("demo_mechanism", model["mechanism"])
                               == model["mechanism"])
    if same and ph is not None and v.present(ph.held):
        # the demonstration shows this mechanism: its grasp and tip path, then checked
        for _ in range(2):
            yield from tool(v, ph, dp)
            yield from look(v, 6)
            if _tool_done(v, press, model, ph):
                return
            ee = v.ee()  # not yet: lift and redo the path's end with the tool held
            yield from move(v, [ee[0], ee[1], ee[2] + 0.03], ee[3], 0.0, tol=0.004)
        return
    # another mechanism than the demonstration's: a generic grasp and the instance's goal
    slot = int(model.get("slot", 0))
    if not v.present(2 * slot):
        slot = 1 - slot
    tool_row, tip = 2 * slot, 2 * slot + 1
    yield from _grasp_from_above(v, tool_row)
    if press:
        ee = v.ee()
        yield from move(v, [ee[0], ee[1], ee[2] + 0.08], ee[3], 0.0, tol=0.004)
        target = v.pos(4)[:2]
        z = 0.10 + (v.ee()[2] - v.pos(tip)[2])  # the tip 10 cm up clears any well's walls
        for _ in range(3):
            ee = v.ee()
            yield from move(v, [*(ee[:2] + target - v.pos(tip)[:2]), z], ee[3], 0.0, tol=0.003)
        yield from look(v, 4)
        yield from servo(v, lambda: (target - v.pos(tip)[:2], 0.0), z, tol=0.0015)
        stuck = 0
        for _ in range(100):  # push down until the target stops the tool
            ee = v.ee()
            yield from move(v, [*(ee[:2] + target - v.pos(tip)[:2]), ee[2] - 0.004], ee[3],
                            0.0, max_steps=1)
            stuck = stuck + 1 if v.ee()[2] > ee[2] - 0.0005 else 0
            if stuck >= 4:
                break
        yield from hold(v, 6, 0.0)
        return
    ee = v.ee()
    yield from move(v, [ee[0], ee[1], 0.08], ee[3], 0.0, tol=0.004)
    goal = v.pos(5)[:2]
    for _ in range(3):  # the tip beyond the target, away from the goal; drag it to the goal
        yield from look(v, 4)
        puck = v.pos(4)[:2]
        u = (goal - puck) / max(float(np.linalg.norm(goal - puck)), 1e-6)
        yaw = math.atan2(-u[1], -u[0])  # the tool points away from the goal
        ee = v.ee()
        yield from move(v, [*ee[:2], 0.08], yaw, 0.0, tol=0.004, speed=0.7)
        for _ in range(3):
            ee, tp = v.ee(), v.pos(tip)
            want = puck - 0.05 * u
            yield from move(v, [*(ee[:2] + want - tp[:2]), ee[2] - (tp[2] - 0.04)], yaw, 0.0,
                            tol=0.003)
        ee, tp = v.ee(), v.pos(tip)
        yield from move(v, [*ee[:2], max(0.012, ee[2] - (tp[2] - 0.003))], yaw, 0.0,
                        speed=0.5, tol=0.002)
        for _ in range(150):
            short = float((v.pos(5)[:2] - v.pos(4)[:2]) @ u)
            if short < 0.003:
                break
            ee, tp = v.ee(), v.pos(tip)
            d = 0.008 if short > 0.03 else 0.003
            side = v.pos(4)[:2] - tp[:2]
            side = side - (side @ u) * u
            yield from move(v, [*(ee[:2] + d * u + 0.5 * side),
                                max(0.012, ee[2] - (tp[2] - 0.003))], yaw, 0.0, max_steps=1)
        ee = v.ee()
        yield from move(v, [*(ee[:2] - 0.01 * u), 0.06], ee[3], 0.0, tol=0.004)
        yield from look(v, 6)
        if abs(float((v.pos(5)[:2] - v.pos(4)[:2]) @ u)) < 0.008:
            break


def _tool_done(v: View, press: bool, model: dict[str, Any], ph: Phase) -> bool:
    """The success condition the demonstration shows: the target pressed down, or the part the
    tool moved where it ended relative to its reference row."""
    if ph.moved is not None and ph.moved_ref is not None and ph.moved_goal is not None \
            and ph.moved_dir is not None:
        goal = v.pos(ph.moved_ref) + ph.moved_goal
        return bool(abs(float((goal[:2] - v.pos(ph.moved)[:2]) @ ph.moved_dir)) < 0.008)
    return bool(model.get("rest", v.pos(4)[2]) - float(v.pos(4)[2]) > 0.004)


SKILLS = {"insertion": insertion, "rotation": rotation, "assembly": assembly,
          "opening": opening, "tool_use": tool_use}
