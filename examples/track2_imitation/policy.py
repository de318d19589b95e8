"""The imitation policy (T-OSVI style): one demonstration in, actions out, no world model.

The policy reads the demonstration as a sequence of hand targets and attends, at every
phase, to one part: which part a phase's motion is relative to is *learned* offline per
family and phase (``train.py``: the part in whose frame the expert's targets vary least
between instances; a row, or the part the demonstration takes at its next grasp). A phase is
one half of a key stage (``phases``): the start of a reach may be relative to one part and
its end to another. At run time::

    goal_k = pose(part_attended(k), at anchor(k))  (+)  rel_k  +  SCALE * c_k[:4]
    a_t    = clip([servo(goal_k - control target), grip_k + c_k[4]], -1, 1)
    c_k    = W^T [s(o_t) - s(d_k), 1]

``rel_k`` is the demonstration's control target after its ``k``-th action in the frame of
the attended part as the demonstration observed it at the *anchor* of step ``k``: the last
grasp annotated at or before ``k`` (the start if none). The frame is frozen while the hand
acts, so a motion that moves the attended part (a turn, a slide) is reproduced as a motion
relative to where the part was when the hand took hold, not cancelled by following the part
as it moves; at run time the anchor pose is the mean of the part's recent measurements when
the pointer passes the anchor (before the first grasp: the latest mean, nothing is held
yet). Training may instead pick a *live* frame for a phase (the part's latest mean, not
frozen: ``LIVE`` added to the attention value) where that makes the runs agree better.
``W`` is a small linear correction fitted on expert rollouts; it moves the goal (so the
servo settles on it: added to the action, it held the target a few millimetres off the goal
and the pointer waited out its patience at every step). The pointer ``k`` advances when the
hand's target is near the goal (the phase follows progress, not the clock), or after
``PATIENCE`` steps; before the demonstration's grip changes (a grasp, a release) the hand
*itself* must be near the goal (the target leads it by up to ``LEAD``: a grip closed there
took the part off-centre, a release let go short of the goal). The grip is the
demonstration's. No stage is checked, nothing is verified, nothing is remembered between
attempts. Numpy only; shared by the agent and the training script.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

ROWS = 6
DIM = 3 * ROWS + 3
DPOS, DYAW, WMAX = 0.015, 0.15, 0.09
SCALE = np.array([DPOS, DPOS, DPOS, DYAW])
LEAD = np.array([0.02, 0.02, 0.02, 0.3])
LO = np.array([-0.30, -0.30, 0.003, -3.2])
HI = np.array([0.30, 0.30, 0.30, 3.2])


def wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def yaw_of(q: np.ndarray) -> float:
    w, x, y, z = (float(v) for v in q)
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def state(proprio: np.ndarray, parts: np.ndarray) -> np.ndarray:
    """``s(o)``: every part's position relative to the hand (hand frame), opening, contacts."""
    p = np.asarray(proprio, dtype=float)
    rows = np.zeros((ROWS, 10))
    parts = np.asarray(parts, dtype=float)
    rows[: min(ROWS, len(parts))] = parts[:ROWS]
    c, s = math.cos(p[3]), math.sin(p[3])
    d = rows[:, 1:4] - p[:3]
    rel = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], d[:, 2]], axis=1)
    rel *= rows[:, :1] > 0.5
    return np.concatenate([rel.ravel(), [p[4] / WMAX, p[5], p[6]]])


def features(current: np.ndarray, demo: np.ndarray) -> np.ndarray:
    return np.append(current - demo, 1.0)


def targets(proprio: np.ndarray, actions: np.ndarray) -> np.ndarray:
    """The demonstration's control targets after each action (the bench's update rule)."""
    hand = np.asarray(proprio, dtype=float)[:, :4]
    t = hand[0].copy()
    out = []
    for k, a in enumerate(np.asarray(actions, dtype=float)):
        t = np.clip(np.clip(t + a[:4] * SCALE, hand[k] - LEAD, hand[k] + LEAD), LO, HI)
        out.append(t.copy())
    return np.asarray(out)


def part_pose(row: np.ndarray) -> np.ndarray:
    return np.array([row[1], row[2], row[3], yaw_of(row[4:8])])


def relative(target: np.ndarray, part: np.ndarray) -> np.ndarray:
    """A hand target in a part's frame."""
    c, s = math.cos(part[3]), math.sin(part[3])
    d = target[:2] - part[:2]
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1], target[2] - part[2],
                     wrap(target[3] - part[3])])


def absolute(rel: np.ndarray, part: np.ndarray) -> np.ndarray:
    c, s = math.cos(part[3]), math.sin(part[3])
    return np.array([part[0] + c * rel[0] - s * rel[1], part[1] + s * rel[0] + c * rel[1],
                     part[2] + rel[2], part[3] + rel[3]])


def stage_of(key_stages: list[tuple[str, int, int]], k: int) -> str:
    for name, a, b in key_stages:
        if a <= k < b:
            return name
    return key_stages[-1][0] if key_stages else ""


def stage_kind(name: str) -> str:
    """The key stage attention is learned for: the stage's own name (``reach_part2`` has its
    own attended part, the one ``part2`` goes onto)."""
    return name


PHASES = 2
"""Each key stage is cut into this many phases of equal length, each with its own attended
part (the start of a reach may move relative to one part, its end relative to another)."""


def phases(stages: list[str]) -> list[str]:
    """The phase of every step, ``<stage kind>#<i>``, from the per-step stage names."""
    out: list[str] = []
    start = 0
    for k in range(len(stages) + 1):
        if k == len(stages) or (k > start and stages[k] != stages[start]):
            n = k - start
            out += [f"{stage_kind(stages[start])}#{min(PHASES - 1, PHASES * i // n)}"
                    for i in range(n)]
            start = k
    return out


def near(a: np.ndarray, b: np.ndarray, tol: np.ndarray) -> bool:
    """Whether poses ``[x, y, z, yaw]`` ``a`` and ``b`` agree within ``tol`` (yaw wrapped)."""
    d = np.abs(np.asarray(a, dtype=float) - b)
    d[3] = abs(wrap(float(a[3] - b[3])))
    return bool(np.all(d < tol))


def anchor_of(anchors: list[int], k: int) -> int:
    """The anchor of demonstration step ``k``: the last of ``anchors`` (grasp steps) at or
    before ``k``, else 0."""
    return max((a for a in anchors if a <= k), default=0)


def mean_pose(poses: list[np.ndarray]) -> np.ndarray:
    """The mean of part poses ``[x, y, z, yaw]`` (the yaw's circular mean)."""
    arr = np.asarray(poses, dtype=float)
    yaw = math.atan2(float(np.mean(np.sin(arr[:, 3]))), float(np.mean(np.cos(arr[:, 3]))))
    return np.array([*arr[:, :3].mean(axis=0), yaw])


TOL = np.array([0.003, 0.003, 0.003, 0.05])
"""How near the hand's target must be to the goal for the pointer to move on (m, rad)."""
GATE_TOL = np.array([0.004, 0.004, 0.004, 0.08])
"""How near the hand itself must be before the demonstration's grip changes (m, rad)."""
GATE_PATIENCE = 24  # steps the hand may take to get there
PATIENCE = 8  # steps at one pointer before it moves on regardless

NEXT = ROWS
"""An attention value meaning "the part the demonstration takes at its next grasp"."""
LIVE = 8
"""Added to an attention value: the part's frame as it is now, not frozen at the grasp."""


def grasped_rows(parts: np.ndarray, grasps: list[int]) -> list[int]:
    """Per grasp step, the row the hand took: the one that moved most until the next grasp
    (or the end)."""
    out = []
    for j, g in enumerate(grasps):
        end = grasps[j + 1] if j + 1 < len(grasps) else len(parts) - 1
        d = np.linalg.norm(parts[end, :, 1:4] - parts[g, :, 1:4], axis=1)
        yaw = np.array([abs(wrap(yaw_of(parts[end, i, 4:8]) - yaw_of(parts[g, i, 4:8])))
                        for i in range(len(parts[g]))])
        score = np.where(parts[g, :, 0] > 0.5, d + 0.05 * yaw, -1.0)
        out.append(int(np.argmax(score[:ROWS])))
    return out


def attended_row(attend: int, parts: np.ndarray, grasps: list[int], taken: list[int],
                 k: int) -> int:
    """The row an attention value means at step ``k``: a row, or (``NEXT``) the row taken at
    the first grasp after ``k`` (the last grasp's after the last)."""
    attend %= LIVE
    if attend != NEXT:
        return attend
    nxt = [r for g, r in zip(grasps, taken, strict=True) if g > k]
    return nxt[0] if nxt else (taken[-1] if taken else 0)


class Policy:
    """One demonstration's policy, for one attempt at a time."""

    def __init__(self, weights: np.ndarray, attend: dict[str, int], proprio: np.ndarray,
                 parts: np.ndarray, actions: np.ndarray,
                 key_stages: list[tuple[str, int, int]], anchors: list[int]) -> None:
        self.w = weights
        self.actions = np.asarray(actions, dtype=float)
        self.states = np.stack([state(p, q) for p, q in zip(proprio, parts, strict=True)])
        tgt = targets(proprio, actions)
        self.rows: list[int] = []
        self.anchors: list[int] = []
        self.live: list[bool] = []
        self.rel = []
        taken = grasped_rows(np.asarray(parts, dtype=float), anchors)
        phase = phases([stage_of(key_stages, k) for k in range(len(actions))])
        for k in range(len(actions)):
            att = attend.get(phase[k], 0)
            row = attended_row(att, np.asarray(parts), anchors, taken, k)
            live = att >= LIVE
            a = k + 1 if live else anchor_of(anchors, k)  # observation k + 1 follows action k
            self.live.append(live)
            if parts[a, row, 0] < 0.5:
                row = 0
            self.rows.append(row)
            self.anchors.append(a)
            self.rel.append(relative(tgt[k], part_pose(parts[a, row])))
        grip = np.sign(self.actions[:, 4])
        self.gate = [bool(grip[k + 1] != grip[k]) if k + 1 < len(grip) else True
                     for k in range(len(grip))]
        self.k = 0
        self.target: np.ndarray | None = None
        self.seen: dict[int, list[np.ndarray]] = {}
        self.frozen: dict[tuple[int, int], np.ndarray] = {}
        self.waited = 0

    def reset(self) -> None:
        self.k, self.target, self.seen, self.frozen = 0, None, {}, {}
        self.waited = 0

    @property
    def done(self) -> bool:
        return self.k >= len(self.actions) - 1

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        prop = np.asarray(obs["proprio"], dtype=float)
        parts = np.asarray(obs["parts"], dtype=float)
        if self.target is None:
            self.target = prop[:4].copy()
        for i in range(min(ROWS, len(parts))):  # fresh measurements of every part
            if parts[i, 0] > 0.5 and parts[i, 9] <= 0.2:
                self.seen.setdefault(i, []).append(part_pose(parts[i]))
        row, key = self.rows[self.k], (self.anchors[self.k], self.rows[self.k])
        now = mean_pose(self.seen[row][-8:]) if row in self.seen else part_pose(parts[row])
        if key[0] == 0 or self.live[self.k]:  # nothing held yet, or a live frame
            self.frozen[key] = now
        elif key not in self.frozen:  # the pointer passed the grasp: freeze the frame
            self.frozen[key] = now
        goal = absolute(self.rel[self.k], self.frozen[key])
        # the correction moves the goal (in action units of one step), so the servo settles
        # on it instead of fighting it, and the pointer's test below sees where it leads
        corr = features(state(prop, parts), self.states[self.k]) @ self.w
        goal = goal + corr[:4] * SCALE
        reached = near(goal, self.target, TOL)
        step = np.clip(goal - self.target, -SCALE, SCALE)
        step[3] = float(np.clip(wrap(goal[3] - self.target[3]), -DYAW, DYAW))
        a = np.append(step / SCALE, self.actions[self.k, 4] + corr[4])
        a = np.clip(a, -1.0, 1.0)
        self.target = np.clip(np.clip(self.target + a[:4] * SCALE, prop[:4] - LEAD,
                                      prop[:4] + LEAD), LO, HI)
        # the pointer moves on when the hand's target reached the goal (before or after this
        # step), or after PATIENCE steps at one pointer (a target the hand cannot reach is
        # passed); before the demonstration's grip changes (a grasp, a release) the hand
        # itself must be at the goal, for up to GATE_PATIENCE steps: the target leads the
        # hand by up to LEAD, and a grip that closes or opens there acts too early
        self.waited += 1
        moved_on = reached or near(goal, self.target, TOL)
        patience = PATIENCE
        if self.gate[self.k]:
            moved_on = moved_on and near(goal, prop[:4], GATE_TOL)
            patience = GATE_PATIENCE
        if moved_on or self.waited >= patience:
            self.k = min(len(self.actions) - 1, self.k + 1)
            self.waited = 0
        return a.astype(np.float32)
