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
from typing import Any

import numpy as np
from controllers import (
    BAR_X,
    HANDLE_Z,
    LID_KNOB,
    LID_PIVOT,
    WMAX,
    Plan,
    View,
    grip,
    hold,
    look,
    move,
    nearest_yaw,
    pick,
    pick_tool,
    release,
    servo,
)
from perception import rot2, wrap


def spiral(spacing: float, rings: int) -> list[np.ndarray]:
    """Offsets on rings of radius ``spacing``, ``2 spacing``, ... nearest first."""
    out = []
    for k in range(1, rings + 1):
        for j in range(6 * k):
            a = 2 * math.pi * j / (6 * k) + 0.5 * k
            out.append(k * spacing * np.array([math.cos(a), math.sin(a)]))
    return out


# -- insertion: align, descend, search around the rim when the peg does not go in ------------
def insertion(v: View, model: dict[str, Any]) -> Plan:
    yield from look(v, 8)
    h = 2 * max(v.pos(0)[2], 0.02)
    hole_xy, hole_yaw = v.pos(1)[:2], v.yaw(1)
    turn = wrap(hole_yaw - v.yaw(0))
    yaw0 = nearest_yaw(v.yaw(0), math.pi / 2, -turn / 2)
    g = 0.022
    lift = 0.05 + h - g

    def bottom() -> np.ndarray:
        return v.p.point(0, -h / 2)

    yield from pick(v, v.pos(0) + [0, 0, h / 2], yaw0, WMAX, g, lift)
    for _ in range(3):
        ee = v.ee()
        yield from move(v, [*(ee[:2] + hole_xy - bottom()[:2]), lift], yaw0 + turn, 0.0, tol=0.003)
    yield from look(v, 4)
    yield from servo(v, lambda: (hole_xy - bottom()[:2], wrap(hole_yaw - v.yaw(0))), lift)
    if not (yield from _press_in(v, v.target[:2], bottom)):
        ee = v.ee()
        centre, base = v.target[:2].copy(), ee[2]
        for off in spiral(0.0018, 4):  # predicted: it drops in; observed: it stays up
            yield from move(v, [*(centre + off), base], ee[3], 0.0, tol=0.0015, max_steps=6)
            if (yield from _press_in(v, centre + off, bottom)):
                model["search_offset"] = [float(x) for x in off]
                break
            yield from move(v, [*(centre + off), base], ee[3], 0.0, max_steps=2)
    yield from release(v, WMAX, 0.05)


def _press_in(v: View, xy: np.ndarray, bottom: Any) -> Any:
    """Descend at ``xy`` until stopped; True when the peg's bottom reached the hole's floor
    (the table), as the model of the held peg says."""
    stuck = 0
    for _ in range(40):
        prev = v.ee()[2]
        yield from move(v, [*xy, prev - 0.004], v.ee()[3], 0.0, max_steps=1)
        stuck = stuck + 1 if v.ee()[2] > prev - 0.0005 else 0
        if stuck >= 3 or bottom()[2] < 0.003:
            break
    return bool(bottom()[2] < 0.006)


# -- rotation: turn, notice a blocked direction, check the turn after letting go ---------------
def rotation(v: View, model: dict[str, Any]) -> Plan:
    yield from look(v, 8)
    axis, z = v.pos(0)[:2], v.pos(0)[2]
    theta0 = v.yaw(0)
    turn = float(model["turn"])
    target = theta0 + turn
    tcp_z = z - 0.005
    done = 0.0  # what the handle turned so far, by the model of the grasp
    for _ in range(3):
        theta = theta0 + done
        yaw0 = nearest_yaw(theta, math.pi, -(target - theta) / 2)
        yield from move(v, [*axis, z + 0.06], yaw0, 0.08, tol=0.004)
        yield from move(v, [*axis, tcp_z], yaw0, 0.08, speed=0.6)
        yield from grip(v, 0.0, 6)
        hand0 = v.ee()[3]
        asked = 0.0
        for _ in range(140):
            turned = v.ee()[3] - hand0
            err = target - (theta + turned)
            if abs(err) < 0.01:
                break
            step = float(np.clip(err, -0.1, 0.1))
            asked += abs(step)
            yield from move(v, [*axis, tcp_z], v.ee()[3] + step, 0.0, max_steps=1)
            if asked > 0.35 and abs(turned) < 0.08:  # predicted to turn; it does not: a stop
                model["turn"] = turn = -turn
                model["direction_flipped"] = True
                target = theta0 + turn
                asked = 0.0
        done = theta + (v.ee()[3] - hand0) - theta0
        yield from hold(v, 3, 0.0)
        yield from release(v, 0.08, 0.06)
        yield from look(v, 10)
        seen = v.yaw(0) - theta0
        done = done + wrap(seen - done)  # the observation corrects the grasp's model
        if abs(turn - done) < 0.02:
            break


# -- opening: find the way it moves, measure its range, set the fraction, check ----------------
def opening(v: View, model: dict[str, Any]) -> Plan:
    yield from look(v, 10)
    origin, frame = v.pos(1)[:2], v.yaw(1)
    local = rot2(-frame, v.pos(0)[:2] - origin)
    if v.pos(0)[2] < 0.025:
        kind, sy = "drawer", 1.0
    elif np.linalg.norm(local) > 0.04:
        kind, sy = "swivel_lid", (1.0 if local[1] > 0 else -1.0)
    else:
        kind = "sliding_cover"
        sy = model.get("sy", 1.0 if abs(local[1]) < 0.004 else float(np.sign(local[1])))
    model["kind"] = kind
    opens = model.get("mode", "open") == "open"
    goal_frac = float(model.get("fraction", 0.8 if opens else 0.2))

    def joint() -> float:
        loc = rot2(-v.yaw(1), v.pos(0)[:2] - v.pos(1)[:2])
        if kind == "drawer":
            return float(-loc[0])
        if kind == "sliding_cover":
            return float(loc[1] * sy)
        return float(wrap(v.yaw(0) - v.yaw(1)) * sy)

    def grasp(q: float) -> tuple[np.ndarray, float]:
        if kind == "drawer":
            loc, zz, yaw = (BAR_X - q, 0.0), HANDLE_Z - 0.004, frame + math.pi / 2
        elif kind == "sliding_cover":
            loc, zz, yaw = (0.0, sy * (-0.03 + q)), 0.061, frame
        else:
            loc = np.array([LID_PIVOT[0], sy * LID_PIVOT[1]]) + rot2(
                sy * q, (LID_KNOB[0], sy * LID_KNOB[1]))
            zz, yaw = 0.061, frame + sy * q
        xy = origin + rot2(frame, loc)
        return np.array([xy[0], xy[1], zz]), yaw

    lim = 0.08 if kind == "swivel_lid" else 0.01
    open_w = 0.032 if kind == "drawer" else 0.07
    limit_guess = 1.7 if kind == "swivel_lid" else 0.15
    for _ in range(3):
        q0 = joint()
        pos, yaw = grasp(q0)
        _, yaw_end = grasp(limit_guess)
        yaw0 = nearest_yaw(yaw, math.pi, -(yaw_end - yaw) / 2)
        yield from move(v, pos + [0, 0, 0.05], yaw0, open_w, tol=0.004)
        yield from move(v, pos, yaw0, open_w, speed=0.6)
        yield from grip(v, 0.0, 6)
        if "range" not in model:  # open to the stop: the range; or find it does not move
            start = best = joint()
            still, moved = 0, False
            for _ in range(160):
                q = joint()
                still = still + 1 if q < best + 0.1 * lim else 0
                best = max(best, q)
                moved = moved or best > start + 2 * lim
                if still >= 8 and moved:
                    model["range"] = best
                    break
                if still >= 14 and not moved:  # predicted to slide; it does not: other way
                    sy = -sy
                    model["sy"] = sy
                    break
                nxt, yaw_n = grasp(q + lim)
                yield from move(v, nxt, yaw0 + wrap(yaw_n - yaw), 0.0, max_steps=1)
            if "range" not in model:
                yield from release(v, open_w, 0.05)
                continue
        goal_q = goal_frac * model["range"]
        for _ in range(150):
            q = joint()
            if abs(goal_q - q) < 0.01 * model["range"]:
                break
            nxt, yaw_n = grasp(q + float(np.clip(goal_q - q, -lim, lim)))
            yield from move(v, nxt, yaw0 + wrap(yaw_n - yaw), 0.0, max_steps=1)
        yield from hold(v, 3, 0.0)
        yield from release(v, open_w, 0.06)
        yield from look(v, 10)
        if abs(joint() / model["range"] - goal_frac) < 0.025:
            break


# -- assembly: the demonstrated stack, each part seated and checked ----------------------------
def assembly(v: View, model: dict[str, Any]) -> Plan:
    yield from look(v, 8)
    n = sum(v.present(i) for i in (1, 2, 3))
    height = 2 * max(v.pos(1)[2], 0.012)
    twist = float(model.get("stack_yaw", 0.0))
    for i in range(n):
        row = i + 1
        for _ in range(3):
            yield from _place(v, i, row, height, twist if i else 0.0)
            yield from look(v, 8)
            err, dz, dyaw = _offsets(v, i, row, height, twist if i else 0.0)
            # the rules' tolerances (5 mm, 0.08 rad), less a little for the estimate's noise
            seated = abs(dz) < 0.003 and abs(dyaw) < 0.07
            if seated and (i == 0 or np.linalg.norm(err) < 0.0045):  # the tray's walls hold
                break


def _offsets(v: View, i: int, row: int, height: float, twist: float
             ) -> tuple[np.ndarray, float, float]:
    sup = 0 if i == 0 else row - 1
    xy = v.pos(sup)[:2]
    top = 0.0 if i == 0 else float(v.pos(sup)[2] + height / 2)
    p = v.pos(row)
    dyaw = wrap(nearest_yaw(v.yaw(sup) + twist - v.yaw(row), math.pi / 2))
    return xy - p[:2], float(p[2] - height / 2 - top), dyaw


def _place(v: View, i: int, row: int, height: float, twist: float) -> Plan:
    err0, _, dyaw0 = _offsets(v, i, row, height, twist)
    yaw = v.yaw(row)
    yaw0 = nearest_yaw(yaw, math.pi / 2, -dyaw0 / 2)
    g = min(0.02, height - 0.012)
    carry = max(i, 1) * height + 0.025 + height - g
    yield from pick(v, v.pos(row) + [0, 0, height / 2], yaw0, WMAX, g, carry)
    for _ in range(2):
        ee = v.ee()
        err, _, dyaw = _offsets(v, i, row, height, twist)
        yield from move(v, [*(ee[:2] + err), carry], ee[3] + dyaw, 0.0, tol=0.003)
    yield from look(v, 4)

    def error() -> tuple[np.ndarray, float]:
        err, _, dyaw = _offsets(v, i, row, height, twist)
        return err, dyaw

    yield from servo(v, error, carry, tol=0.001, yaw_tol=0.02)
    yield from _lower(v, i, row, height, twist)
    if i == 0 and _offsets(v, i, row, height, twist)[1] > 0.002:  # on the tray's rim: search
        centre, base = v.ee()[:2].copy(), v.ee()[2]
        for off in spiral(0.003, 2):
            yield from move(v, [*(centre + off), base + 0.006], v.ee()[3], 0.0, tol=0.0015,
                            max_steps=4)
            yield from _lower(v, i, row, height, twist)
            if _offsets(v, i, row, height, twist)[1] < 0.002:
                break
    yield from hold(v, 2, 0.0)
    yield from release(v, WMAX, 0.04)


def _lower(v: View, i: int, row: int, height: float, twist: float) -> Plan:
    stuck = 0
    for _ in range(40):
        dz = _offsets(v, i, row, height, twist)[1]
        if dz < 0.001 or stuck >= 3:
            return
        ee = v.ee()
        yield from move(v, [*ee[:2], ee[2] - min(0.008, max(0.002, dz / 2))], ee[3], 0.0,
                        max_steps=1)
        stuck = stuck + 1 if v.ee()[2] > ee[2] - 0.0005 else 0


# -- tool use: the mechanism this instance has, then press or pull, checked ---------------------
def tool_use(v: View, model: dict[str, Any]) -> Plan:
    yield from look(v, 8)
    press = bool(v.pos(4)[0] < 0.3)  # a target within the hand's reach sits in a well
    model["mechanism"] = "press" if press else "pull"
    slot, _ = pick_tool(v, press)
    tool, tip = 2 * slot, 2 * slot + 1
    tool_yaw = v.yaw(tool)
    top = v.p.point(tool, 0.015 if press else 0.03)
    if press:
        rest = float(v.pos(4)[2])
        yield from pick(v, top, nearest_yaw(tool_yaw, math.pi / 2), 0.045, 0.054,
                        top[2] + 0.021)
        target = v.pos(4)[:2]
        z = 0.10 + (v.ee()[2] - v.pos(tip)[2])  # the tip 10 cm up clears any well's walls
        for _ in range(3):  # push; check the button went down; again if it did not
            for _ in range(3):
                ee = v.ee()
                yield from move(v, [*(ee[:2] + target - v.pos(tip)[:2]), z], ee[3], 0.0,
                                tol=0.003)
            yield from look(v, 4)
            yield from servo(v, lambda: (target - v.pos(tip)[:2], 0.0), z, tol=0.0015)
            stuck = 0
            for _ in range(100):
                ee = v.ee()
                prev = ee[2]
                yield from move(v, [*(ee[:2] + target - v.pos(tip)[:2]), ee[2] - 0.004], ee[3],
                                0.0, max_steps=1)
                stuck = stuck + 1 if v.ee()[2] > prev - 0.0005 else 0
                if stuck >= 4:
                    break
            yield from hold(v, 6, 0.0)
            if rest - float(v.pos(4)[2]) > 0.005:
                break
        return
    turn = wrap(0.0 - tool_yaw)
    yaw0 = nearest_yaw(tool_yaw, math.pi, -turn / 2)
    yield from pick(v, top, yaw0, 0.045, min(0.054, top[2] - 0.004), 0.08)
    ee = v.ee()
    yield from move(v, [*ee[:2], 0.08], yaw0 + turn, 0.0, tol=0.004, speed=0.7)
    goal_x = float(v.pos(5)[0])
    for _ in range(3):  # blade behind the puck, pull to the line, check, again
        yield from look(v, 4)
        puck = v.pos(4)
        for _ in range(3):
            ee, tp = v.ee(), v.pos(tip)
            want = np.array([puck[0] + 0.05, puck[1]])
            yield from move(v, [*(ee[:2] + want - tp[:2]), ee[2] - (tp[2] - 0.04)], yaw0 + turn,
                            0.0, tol=0.003)
        ee, tp = v.ee(), v.pos(tip)
        yield from move(v, [*ee[:2], max(0.012, ee[2] - (tp[2] - 0.003))], yaw0 + turn, 0.0,
                        speed=0.5, tol=0.002)
        for _ in range(150):
            puck = v.pos(4)
            if puck[0] - goal_x < 0.003:
                break
            ee, tp = v.ee(), v.pos(tip)
            speed = 0.008 if puck[0] - goal_x > 0.03 else 0.003
            yield from move(v, [ee[0] - speed, ee[1] + 0.5 * (puck[1] - tp[1]),
                                max(0.012, ee[2] - (tp[2] - 0.003))], yaw0 + turn, 0.0,
                            max_steps=1)
        ee = v.ee()
        yield from move(v, [ee[0] + 0.01, ee[1], 0.06], ee[3], 0.0, tol=0.004)
        yield from look(v, 6)
        if abs(v.pos(4)[0] - goal_x) < 0.008:
            break


SKILLS = {"insertion": insertion, "rotation": rotation, "assembly": assembly,
          "opening": opening, "tool_use": tool_use}
