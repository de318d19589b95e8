"""``ObservedEye``: part poses estimated from the observations, for the feasibility expert.

The scripted expert reads part poses through an :class:`~simhost.worlds.track2._family.Eye`. The
privileged oracle uses the simulation itself; the feasibility check uses this eye, which
sees exactly what an agent sees (the ``parts`` rows and ``proprio`` of each observation) and
keeps, per row, a simple estimate:

- a part at rest: the running mean of its measurements (restarted when a measurement lies
  too far from it: the part was moved);
- a part held in the gripper (both fingers in contact, the part within reach of the hand):
  the running mean of its pose *in the hand's frame*, from measurements paired with the hand
  pose at the time they show (the latency is known); between measurements, and while the
  gripper hides the part, it moves with the hand.

Yaws are unwrapped near the current estimate, so a part whose yaw is reported modulo its
symmetry keeps a continuous yaw; the first measurement is unwrapped near a prior when one is
given (the expert knows the instance's nominal poses). It is a baseline of a perception
model, nothing more: an agent may do better.
"""

from __future__ import annotations

import math
from collections import deque
from typing import TYPE_CHECKING

import numpy as np

from ._bench import CONTROL_HZ, WIDTH_MAX, rot2
from ._config import ObservationConfig
from ._observe import with_yaw

if TYPE_CHECKING:
    from ._family import FamilyTask

REACH = 0.05  # m: a part this close to the TCP while both fingers touch something is held


def _near(value: float, ref: float, period: float) -> float:
    """The value equivalent to ``value`` modulo ``period`` that is closest to ``ref``."""
    return ref + (value - ref + period / 2) % period - period / 2


class _Track:
    """The estimate of one row."""

    def __init__(self) -> None:
        self.n = 0
        self.p = np.zeros(3)
        self.yaw = 0.0
        self.q = np.array([1.0, 0.0, 0.0, 0.0])
        self.rel_n = 0
        self.rel_p = np.zeros(3)
        self.rel_yaw = 0.0
        self.held = False


class ObservedEye:
    """Part poses from observations; see the module docstring.

    Args:
      task: the family task (row layout and symmetries).
      config: the split's observation channel (noise, latency, symmetric yaws).
      priors: per row, a yaw near which a part's first measurement is unwrapped.
      links: per row, the row it is rigidly attached to (a tool's tip to its handle).
    """

    def __init__(self, task: FamilyTask, config: ObservationConfig,
                 priors: dict[int, float] | None = None,
                 links: dict[int, int] | None = None) -> None:
        self.task = task
        self.cfg = config
        refs = task.row_refs()
        self._body = {ref[1]: i for i, ref in enumerate(refs) if ref and ref[0] == "body"}
        self._site = {ref[1]: i for i, ref in enumerate(refs) if ref and ref[0] == "site"}
        self._periods = task.symmetry() if config.symmetric_yaw else (2 * math.pi,) * len(refs)
        self._priors = dict(priors or {})
        self._links = dict(links or {})
        self._reach = {i: task.row_reach().get(i, REACH) for i in range(len(refs))}
        self._movable = task.held_rows()
        self._tracks = [_Track() for _ in refs]
        self._hands: deque[np.ndarray] = deque(maxlen=config.latency_steps + 1)
        self._hand = np.zeros(4)
        self._fresh = config.latency_steps / CONTROL_HZ + 1e-6
        self._pos_gate = max(4.0 * config.pose_noise_m, 0.003)
        self._yaw_gate = max(4.0 * config.yaw_noise_rad, 0.05)

    # ------------------------------------------------------------------ feeding
    def update(self, obs: dict[str, np.ndarray]) -> None:
        """Take one observation (call after reset and after every step)."""
        prop = np.asarray(obs["proprio"], dtype=float)
        self._hand = prop[:4].copy()
        self._hands.append(self._hand.copy())
        holding = prop[5] > 0.5 and prop[6] > 0.5 and prop[4] < 0.95 * WIDTH_MAX
        rows = np.asarray(obs["parts"], dtype=float)
        then = self._hands[0]
        for i, tr in enumerate(self._tracks):
            row = rows[i]
            if row[0] < 0.5:
                continue
            parent = self._links.get(i)
            if parent is not None:
                held = self._tracks[parent].held
            else:
                near = np.linalg.norm(self._current(tr)[:3] - self._hand[:3]) < self._reach[i]
                held = bool(holding and i in self._movable and tr.n + tr.rel_n > 0 and near)
            if held and not tr.held:  # just grasped: start from where it was seen at rest
                tr.rel_p, tr.rel_yaw = self._to_hand(tr.p, tr.yaw, self._hand)
                tr.rel_n = 1 if tr.n else 0
            elif tr.held and not held:  # just released: it rests where the hand left it
                tr.p, tr.yaw = self._from_hand(tr.rel_p, tr.rel_yaw, self._hand)
                tr.n = 1
            tr.held = held
            if row[9] > self._fresh:
                continue  # no new measurement of this row
            pm, qm = row[1:4], row[4:8]
            ym = math.atan2(2 * (qm[0] * qm[3] + qm[1] * qm[2]), 1 - 2 * (qm[2] ** 2 + qm[3] ** 2))
            period = self._periods[i]
            tr.q = qm.copy()
            if held:
                rel_p, rel_yaw = self._to_hand(pm, ym, then)
                if tr.rel_n:
                    rel_yaw = _near(rel_yaw, tr.rel_yaw, period)
                    if np.linalg.norm(rel_p - tr.rel_p) > self._pos_gate * 2:
                        tr.rel_n = 0  # it slipped in the grasp
                k = min(tr.rel_n, 30)
                tr.rel_p = (tr.rel_p * k + rel_p) / (k + 1)
                tr.rel_yaw = (tr.rel_yaw * k + rel_yaw) / (k + 1)
                tr.rel_n += 1
                continue
            if tr.n:
                ym = _near(ym, tr.yaw, period)
                if (np.linalg.norm(pm - tr.p) > self._pos_gate
                        or abs(ym - tr.yaw) > self._yaw_gate):
                    tr.n = 0  # it moved: start again
            elif i in self._priors:
                ym = _near(ym, self._priors[i], period)
            k = min(tr.n, 40)
            tr.p = (tr.p * k + pm) / (k + 1)
            tr.yaw = (tr.yaw * k + ym) / (k + 1)
            tr.n += 1

    # ------------------------------------------------------------------ the Eye protocol
    def pos(self, body: int) -> np.ndarray:
        return self._current(self._tracks[self._body[body]])[:3]

    def yaw(self, body: int) -> float:
        return float(self._current(self._tracks[self._body[body]])[3])

    def quat(self, body: int) -> np.ndarray:
        tr = self._tracks[self._body[body]]
        return with_yaw(tr.q, float(self._current(tr)[3]))

    def point(self, body: int, local: tuple[float, float, float]) -> np.ndarray:
        tr = self._tracks[self._body[body]]
        cur = self._current(tr)
        q = with_yaw(tr.q, float(cur[3]))
        w, x, y, z = q
        mat = np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ])
        return cur[:3] + mat @ np.asarray(local, dtype=float)

    def tilt(self, body: int) -> float:
        q = self._tracks[self._body[body]].q
        zz = 1 - 2 * (q[1] ** 2 + q[2] ** 2)
        return math.acos(max(-1.0, min(1.0, zz)))

    def site(self, site: int) -> np.ndarray:
        return self._current(self._tracks[self._site[site]])[:3]

    def known(self, body: int) -> bool:
        """Whether the row of ``body`` has an estimate yet."""
        tr = self._tracks[self._body[body]]
        return tr.n + tr.rel_n > 0

    # ------------------------------------------------------------------ internals
    def _current(self, tr: _Track) -> np.ndarray:
        if tr.held and tr.rel_n:
            p, yaw = self._from_hand(tr.rel_p, tr.rel_yaw, self._hand)
            return np.array([*p, yaw])
        return np.array([*tr.p, tr.yaw])

    @staticmethod
    def _to_hand(p: np.ndarray, yaw: float, hand: np.ndarray) -> tuple[np.ndarray, float]:
        d = np.asarray(p, dtype=float) - hand[:3]
        return np.array([*rot2(-hand[3], d[:2]), d[2]]), float(yaw - hand[3])

    @staticmethod
    def _from_hand(rel: np.ndarray, rel_yaw: float, hand: np.ndarray) -> tuple[np.ndarray, float]:
        xy = hand[:2] + rot2(hand[3], rel[:2])
        return np.array([xy[0], xy[1], hand[2] + rel[2]]), float(hand[3] + rel_yaw)
