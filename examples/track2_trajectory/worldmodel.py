"""The trajectory baseline's world model: how a part moves under the hand, and a planner.

``PartDynamics`` predicts one control step of a part's motion (x, y, z, yaw) from the
hand's motion over that step, whether the hand holds the part, and where the part sits
relative to the hand, per kind of part (``KINDS``: a free part, a knob on its vertical
axis, a drawer, a sliding cover, a swivel lid). Everything is in the part's own frame at
the step's start, so one linear map per kind covers every pose of the bench::

    d_part = W[kind].T @ features(d_hand, held, offset)

``W`` (``dynamics.npz``, a few hundred floats) is fitted by ridge regression in
``train.py`` on instances generated through the public gymnasium benches. ``plan_step``
is the planner: a cross-entropy search over the hand's next displacement whose predicted
part pose, rolled out over a short horizon, comes nearest a target pose while the hand
stays where the grasp puts it. numpy only.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

KINDS = ("free", "knob", "drawer", "sliding_cover", "swivel_lid")
DIM = 8  # features per step
HOLD_REACH = 0.08  # m: a part farther than this from the fingers is not held
HERE = Path(__file__).resolve().parent


def rot2(yaw: float, v: Any) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def wrap(a: Any) -> Any:
    return (np.asarray(a) + math.pi) % (2 * math.pi) - math.pi


def kind_of(family: str, row: int, mechanism: str = "drawer") -> str:
    """The kind of a part row: a rotation's knob, an opening's mover, or a free part."""
    if family == "rotation" and row == 0:
        return "knob"
    if family == "opening" and row == 0:
        return mechanism if mechanism in KINDS else "drawer"
    return "free"


# The rows the hand can move, per family (the public part rows of the track README; a
# tool's tip row and the tool-use target move with a tool, not the hand, and are left out).
MOVABLE = {"insertion": (0,), "rotation": (0,), "assembly": (1, 2, 3), "opening": (0,),
           "tool_use": (0, 2)}


def held_row(proprio: np.ndarray, rows: np.ndarray, movable: tuple[int, ...]) -> int:
    """The movable row the hand holds (both fingers touching; with one movable row, that
    row, wherever its origin is (a lid's or a cover's frame sits at its hinge or slide, not
    at the knob the hand holds); else the nearest present row within ``HOLD_REACH`` of the
    fingers), or -1. ``rows``: (N, >=4) present, x, y, z."""
    if not (proprio[5] > 0.5 and proprio[6] > 0.5 and proprio[4] > 0.004):
        return -1
    if len(movable) == 1:
        return movable[0] if rows[movable[0], 0] > 0.5 else -1
    best, dist = -1, HOLD_REACH
    for i in movable:
        if rows[i, 0] > 0.5:
            d = float(np.linalg.norm(rows[i, 1:4] - proprio[:3]))
            if d < dist:
                best, dist = i, d
    return best


def features(d_hand: np.ndarray, hold: float, offset: np.ndarray, yaw: float) -> np.ndarray:
    """One step's features in the part's frame (``yaw``: the part's yaw at the start).

    ``d_hand``: the hand's (dx, dy, dz, dyaw) over the step (world); ``offset``: the part's
    xy minus the hand's at the start (world)."""
    d = rot2(-yaw, d_hand[:2])
    r = rot2(-yaw, offset)
    w = float(d_hand[3])
    return np.array([hold * d[0], hold * d[1], hold * d_hand[2], hold * w,
                     -hold * w * r[1], hold * w * r[0], hold, 1.0])


def to_world(d_local: np.ndarray, yaw: float) -> np.ndarray:
    xy = rot2(yaw, d_local[:2])
    return np.array([xy[0], xy[1], d_local[2], d_local[3]])


def rigid(f: np.ndarray) -> np.ndarray:
    """The floor model: a held part moves rigidly with the hand, a free one stays."""
    return np.array([f[0] + f[4], f[1] + f[5], f[2], f[3]])


class PartDynamics:
    """One linear step model per kind of part (``dynamics.npz``)."""

    def __init__(self, weights: dict[str, np.ndarray]) -> None:
        self.w = {k: np.asarray(weights[k], dtype=float) for k in KINDS if k in weights}

    @classmethod
    def load(cls, path: Path | None = None) -> PartDynamics:
        with np.load(path or HERE / "dynamics.npz", allow_pickle=False) as npz:
            return cls({k: npz[k] for k in npz.files})

    def step(self, kind: str, part: np.ndarray, d_hand: np.ndarray, hold: float,
             hand_xy: np.ndarray) -> np.ndarray:
        """The part's pose (x, y, z, yaw) one step later."""
        f = features(d_hand, hold, part[:2] - hand_xy, float(part[3]))
        w = self.w.get(kind)
        d = rigid(f) if w is None else f @ w
        return part + to_world(d, float(part[3]))

    def rollout(self, kind: str, part: np.ndarray, hand: np.ndarray, d_hands: np.ndarray,
                hold: float) -> tuple[np.ndarray, np.ndarray]:
        """Part and hand poses after each step of ``d_hands`` (N, H, 4), applied in turn;
        returns (N, H, 4) each."""
        n = len(d_hands)
        parts = np.repeat(part[None, :], n, axis=0)
        hands = np.repeat(hand[None, :], n, axis=0)
        w = self.w.get(kind)
        out_parts, out_hands = [], []
        for t in range(d_hands.shape[1]):
            dh = d_hands[:, t]
            yaw = parts[:, 3]
            c, s = np.cos(yaw), np.sin(yaw)
            off = parts[:, :2] - hands[:, :2]
            d = np.stack([c * dh[:, 0] + s * dh[:, 1], -s * dh[:, 0] + c * dh[:, 1]], 1)
            r = np.stack([c * off[:, 0] + s * off[:, 1], -s * off[:, 0] + c * off[:, 1]], 1)
            wz = dh[:, 3]
            f = np.stack([hold * d[:, 0], hold * d[:, 1], hold * dh[:, 2], hold * wz,
                          -hold * wz * r[:, 1], hold * wz * r[:, 0],
                          np.full(n, hold), np.ones(n)], 1)
            loc = (np.stack([f[:, 0] + f[:, 4], f[:, 1] + f[:, 5], f[:, 2], f[:, 3]], 1)
                   if w is None else f @ w)
            parts = parts + np.stack([c * loc[:, 0] - s * loc[:, 1],
                                      s * loc[:, 0] + c * loc[:, 1], loc[:, 2], loc[:, 3]], 1)
            hands = hands + dh
            out_parts.append(parts)
            out_hands.append(hands)
        return np.stack(out_parts, 1), np.stack(out_hands, 1)


def plan_step(model: PartDynamics, kind: str, part: np.ndarray, hand: np.ndarray,
              target: np.ndarray, grasp: np.ndarray | None, guess: np.ndarray, *,
              horizon: int = 3, samples: int = 48, iters: int = 3,
              rng: np.random.Generator | None = None) -> np.ndarray:
    """The hand's next displacement (dx, dy, 0, dyaw), chosen by a cross-entropy search.

    Cost of a candidate held for ``horizon`` steps, summed over the steps: the predicted
    part's distance to ``target`` (1 cm or 0.1 rad counts 1), plus, with ``grasp`` (the
    hand in the part's frame), the hand's distance from where that grasp on the predicted
    part puts it (the hand must not pull out of the grasp). Summed, the cost prefers the
    displacement that gets there soonest. ``guess`` seeds the search's mean."""
    rng = rng or np.random.default_rng(0)
    lim = np.array([0.012, 0.012, 0.0, 0.12])
    mean = np.clip(np.asarray(guess, dtype=float), -lim, lim)
    sd = np.array([0.005, 0.005, 0.0, 0.05])
    best, best_cost = mean, math.inf
    for _ in range(iters):
        cand = np.clip(mean + sd * rng.standard_normal((samples, 4)), -lim, lim)
        cand[0] = mean
        seq = np.repeat(cand[:, None, :], horizon, axis=1)
        parts, hands = model.rollout(kind, part, hand, seq, 1.0)
        cost = ((np.linalg.norm(parts[..., :2] - target[:2], axis=-1) / 0.01) ** 2
                + (wrap(parts[..., 3] - target[3]) / 0.1) ** 2).sum(axis=1)
        if grasp is not None:
            c, s = np.cos(parts[..., 3]), np.sin(parts[..., 3])
            want = parts[..., :2] + np.stack([c * grasp[0] - s * grasp[1],
                                              s * grasp[0] + c * grasp[1]], -1)
            cost = cost + ((np.linalg.norm(hands[..., :2] - want, axis=-1) / 0.01) ** 2
                           + (wrap(hands[..., 3] - parts[..., 3] - grasp[3]) / 0.3) ** 2
                           ).sum(axis=1)
        order = np.argsort(cost)
        if cost[order[0]] < best_cost:
            best, best_cost = cand[order[0]], float(cost[order[0]])
        elite = cand[order[:6]]
        mean, sd = elite.mean(axis=0), elite.std(axis=0) + 1e-4
    return np.asarray(best)
