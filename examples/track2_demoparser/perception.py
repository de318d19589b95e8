"""Part poses from Track 2 observations: what a team needs before any controller.

On the official splits the ``parts`` rows are measurements: noisy (about a millimetre, a
degree), refreshed every few steps, ``age`` seconds old, kept stale while the gripper hides
a part, and a symmetric part's yaw is only known modulo its symmetry. ``Perception`` keeps,
per row:

- at rest: the running mean of its measurements, restarted when one lies too far away (the
  part was moved);
- while held (both fingers in contact, the part within reach of the hand, and the caller
  says the row is movable): its pose in the hand's frame, from measurements paired with the
  hand pose at the time they show (``age`` says when) — so a held part moves with the hand
  between measurements and while hidden;
- yaws unwrapped near the current estimate; a jump of about pi/3, pi/2 or pi (a symmetric
  part's reported yaw flipping across its period) is folded back.

Numpy only. Used by the demo-parser and task-model baselines.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

HZ = 20
WMAX = 0.09
PERIODS = (math.pi / 3, math.pi / 2, math.pi, 2 * math.pi)


def wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def yaw_of(q: np.ndarray) -> float:
    w, x, y, z = (float(v) for v in q)
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def rot2(yaw: float, v: Any) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def fold(d: float) -> float:
    """A yaw difference with symmetry flips (multiples of pi/3, pi/2, pi, 2 pi) removed."""
    d = wrap(d)
    if abs(d) < 0.3:
        return d
    best = d
    for period in PERIODS:
        r = d - period * round(d / period)
        if abs(r) < abs(best):
            best = r
    return best


class _Row:
    def __init__(self) -> None:
        self.n = 0
        self.p = np.zeros(3)
        self.yaw = 0.0
        self.tilt_q = np.array([1.0, 0.0, 0.0, 0.0])
        self.rel_n = 0
        self.rel_p = np.zeros(3)
        self.rel_yaw = 0.0
        self.held = False
        self.last_age = -1.0


class Perception:
    """Filtered part poses; see the module docstring.

    Args:
      rows: number of ``parts`` rows.
      movable: rows the gripper may carry or drive.
      reach: per row, how far from the hand a held part's reported position may lie (m).
      links: rows rigidly attached to another row (a tool's tip to its handle).
    """

    def __init__(self, rows: int, movable: set[int], reach: dict[int, float] | None = None,
                 links: dict[int, int] | None = None) -> None:
        self.rows = [_Row() for _ in range(rows)]
        self.movable = set(movable)
        self.reach = dict(reach or {})
        self.links = dict(links or {})
        self.hands: deque[np.ndarray] = deque(maxlen=40)
        self.hand = np.zeros(4)
        self.present = np.zeros(rows, dtype=bool)

    def update(self, obs: dict[str, Any]) -> None:
        """Take one observation (after reset and after every step)."""
        prop = np.asarray(obs["proprio"], dtype=float)
        self.hand = prop[:4].copy()
        self.hands.append(self.hand.copy())
        holding = prop[5] > 0.5 and prop[6] > 0.5 and prop[4] < 0.95 * WMAX
        parts = np.asarray(obs["parts"], dtype=float)
        for i, r in enumerate(self.rows):
            row = parts[i]
            self.present[i] = row[0] > 0.5
            if not self.present[i]:
                continue
            parent = self.links.get(i)
            if parent is not None:
                held = self.rows[parent].held
            else:
                near = np.linalg.norm(self._now(r)[:3] - self.hand[:3]) < self.reach.get(i, 0.05)
                held = bool(holding and i in self.movable and r.n + r.rel_n > 0 and near)
            if held and not r.held:
                r.rel_p, r.rel_yaw = self._to_hand(r.p, r.yaw, self.hand)
                r.rel_n = 1 if r.n else 0
            elif r.held and not held:
                r.p, r.yaw = self._from_hand(r.rel_p, r.rel_yaw, self.hand)
                r.n = 1
            r.held = held
            age = float(row[9])
            fresh = age < r.last_age or r.last_age < 0 or age <= 0.0
            r.last_age = age
            if not fresh:
                continue
            lag = int(round(age * HZ))
            then = self.hands[max(0, len(self.hands) - 1 - lag)]
            pm, qm = row[1:4], row[4:8]
            ym = yaw_of(qm)
            r.tilt_q = qm.copy()
            if held:
                rel_p, rel_yaw = self._to_hand(pm, ym, then)
                if r.rel_n:
                    rel_yaw = r.rel_yaw + fold(rel_yaw - r.rel_yaw)
                    if np.linalg.norm(rel_p - r.rel_p) > 0.008:
                        r.rel_n = 0
                k = min(r.rel_n, 30)
                r.rel_p = (r.rel_p * k + rel_p) / (k + 1)
                r.rel_yaw = (r.rel_yaw * k + rel_yaw) / (k + 1)
                r.rel_n += 1
                continue
            if r.n:
                ym = r.yaw + fold(ym - r.yaw)
                if np.linalg.norm(pm - r.p) > 0.005 or abs(ym - r.yaw) > 0.08:
                    r.n = 0
            k = min(r.n, 40)
            r.p = (r.p * k + pm) / (k + 1)
            r.yaw = (r.yaw * k + ym) / (k + 1)
            r.n += 1

    # ------------------------------------------------------------------ reading
    def pos(self, i: int) -> np.ndarray:
        return self._now(self.rows[i])[:3]

    def yaw(self, i: int) -> float:
        return float(self._now(self.rows[i])[3])

    def held(self, i: int) -> bool:
        return self.rows[i].held

    def settled(self, i: int) -> int:
        """How many measurements the current estimate of row ``i`` averages."""
        r = self.rows[i]
        return r.rel_n if r.held else r.n

    def z_axis(self, i: int) -> np.ndarray:
        w, x, y, z = self.rows[i].tilt_q
        return np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])

    def point(self, i: int, dz: float) -> np.ndarray:
        """The point ``dz`` along row ``i``'s own z axis from its origin."""
        return self.pos(i) + self.z_axis(i) * dz

    def _now(self, r: _Row) -> np.ndarray:
        if r.held and r.rel_n:
            p, yaw = self._from_hand(r.rel_p, r.rel_yaw, self.hand)
            return np.array([*p, yaw])
        return np.array([*r.p, r.yaw])

    @staticmethod
    def _to_hand(p: np.ndarray, yaw: float, hand: np.ndarray) -> tuple[np.ndarray, float]:
        d = np.asarray(p, dtype=float) - hand[:3]
        return np.array([*rot2(-hand[3], d[:2]), d[2]]), float(yaw - hand[3])

    @staticmethod
    def _from_hand(rel: np.ndarray, rel_yaw: float, hand: np.ndarray) -> tuple[np.ndarray, float]:
        xy = hand[:2] + rot2(hand[3], rel[:2])
        return np.array([xy[0], xy[1], hand[2] + rel[2]]), float(hand[3] + rel_yaw)
