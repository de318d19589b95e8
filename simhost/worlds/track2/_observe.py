"""The observation channel: part poses as a robot's camera pipeline would give them.

``PartsChannel`` turns the true poses of a family's parts (``FamilyTask.parts``) into the
``parts`` observation under an :class:`~simhost.worlds.track2.ObservationConfig`:

- every ``period_steps`` control steps it *measures*: each row shows the part as it was
  ``latency_steps`` steps earlier, seen through the episode's calibration error (a yaw about
  the table's origin and a translation, common to every part), plus the part's own bias
  (both drawn once per episode) plus Gaussian noise per axis, its yaw likewise and, when
  ``symmetric_yaw``,
  reported modulo the part's symmetry period (the tilt is kept); the ``joint`` column is
  the true joint value only with ``joint_readings``;
- a row whose part the gripper hides from the cameras at that time (``occlusion``: from
  each of the bench's cameras (``CAMERAS``: ``overview``, ``front`` and ``top``), every line
  of sight to the part's sample points — the centre, top and bottom of each of its collision
  geoms, or the site a row shows — meets a gripper geom first; the rays see every geom group
  but ``VISUAL_GROUP``, the visual-only geoms) keeps its previous measurement. A part seen
  past the gripper by any one camera is measured. What leaves a camera's field of view is
  not hidden by that: the channel models a pose estimator over the three cameras, whose
  fields cover the table where the parts rest, not the loss of a part carried out of them;
- the ``age`` column says how old the state shown is, in seconds (latency included).

At reset every part is measured from the reset state, occluded or not. The noise is drawn
for every row at every measurement, occluded or not, so the sequence of random numbers (and
with it the noise an agent meets) does not depend on what the agent does.
"""

from __future__ import annotations

import math
from collections import deque
from typing import TYPE_CHECKING

import numpy as np

from ._bench import CAMERAS, CONTROL_HZ, PART_FIELDS, RAY_GROUPS, VISUAL_GROUP, wrap, yaw_of
from ._config import ObservationConfig

if TYPE_CHECKING:
    from ._family import FamilyTask

_HAND_BODIES = ("hand", "finger_l", "finger_r")


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of two (w, x, y, z) quaternions."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ])


def quat_z(yaw: float) -> np.ndarray:
    """The quaternion of a rotation by ``yaw`` about z."""
    return np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])


def with_yaw(q: np.ndarray, yaw: float) -> np.ndarray:
    """``q`` with its yaw replaced by ``yaw`` (its tilt kept)."""
    tilt = quat_mul(quat_z(-yaw_of(q)), q)
    out = quat_mul(quat_z(yaw), tilt)
    return out / np.linalg.norm(out)


def canonical_yaw(yaw: float, period: float) -> float:
    """``yaw`` folded into [-period/2, period/2): what a symmetric part shows."""
    if period >= 2 * math.pi - 1e-9:
        return wrap(yaw)
    return yaw - period * math.floor(yaw / period + 0.5)


class PartsChannel:
    """The ``parts`` rows of one episode, measured through the configured channel."""

    def __init__(self, task: FamilyTask, config: ObservationConfig) -> None:
        self.task = task
        self.cfg = config
        self.n = len(task.part_names)
        sim = task.s
        m = sim.model
        self._hand = {int(m.body(b).id) for b in _HAND_BODIES}
        self._cams = [int(m.camera(name).id) for name in CAMERAS]
        self._geomid = np.zeros(1, dtype=np.int32)
        self._periods = np.array(task.symmetry(), dtype=float)
        self._samples: list[tuple[str, list[int]]] = []
        for ref in task.row_refs():
            if ref is None:
                self._samples.append(("none", []))
            elif ref[0] == "site":
                self._samples.append(("site", [ref[1]]))
            else:
                mine = (m.geom_bodyid == ref[1]) & (m.geom_group != VISUAL_GROUP)
                geoms = [int(g) for g in np.nonzero(mine)[0]][:8]
                self._samples.append(("geom", geoms))
        self._history: deque[tuple[np.ndarray, np.ndarray | None]] = deque(
            maxlen=config.latency_steps + 1)
        self.rows = np.zeros((self.n, len(PART_FIELDS)))
        self._measured_at = np.zeros(self.n, dtype=np.int64)
        self._step = 0
        self._bias_p = np.zeros((self.n, 3))
        self._bias_y = np.zeros(self.n)
        self._calib_t = np.zeros(3)
        self._calib_yaw = 0.0

    # ------------------------------------------------------------------ public
    def reset(self, rng: np.random.Generator, bias_rng: np.random.Generator | None = None) -> None:
        """Draw the parts' biases (from ``bias_rng``, else ``rng``) and measure every part from
        the reset state."""
        cfg, src = self.cfg, bias_rng or rng
        self._bias_p = src.normal(0.0, 1.0, (self.n, 3)) * cfg.pose_bias_m * [1.0, 1.0, 0.5]
        self._bias_y = src.normal(0.0, 1.0, self.n) * cfg.yaw_bias_rad
        if cfg.calib_m > 0 or cfg.calib_rad > 0:  # drawn only when used: dev draws as before
            self._calib_t = src.normal(0.0, 1.0, 3) * cfg.calib_m * [1.0, 1.0, 0.5]
            self._calib_yaw = float(src.normal(0.0, 1.0)) * cfg.calib_rad
        self._history.clear()
        self._step = 0
        truth = self.task.parts()
        self._history.append((truth, None))
        self.rows[:] = 0.0
        self._measure(rng, truth, np.zeros(self.n, dtype=bool))

    def after_step(self, rng: np.random.Generator) -> bool:
        """Record the state after one control step; measure when due. True if measured."""
        self._step += 1
        k, lat = self._step, self.cfg.latency_steps
        due_later = (k + lat) % self.cfg.period_steps == 0
        truth = self.task.parts()
        hidden = self._occluded(truth) if (due_later and self.cfg.occlusion) else None
        self._history.append((truth, hidden))
        if k % self.cfg.period_steps != 0:
            self._age()
            return False
        old, old_hidden = self._history[0]
        if old_hidden is None:
            old_hidden = np.zeros(self.n, dtype=bool)
        self._measure(rng, old, old_hidden)
        return True

    # ------------------------------------------------------------------ internals
    def _age(self) -> None:
        lat = self.cfg.latency_steps
        present = self.rows[:, 0] > 0.5
        age = (self._step - self._measured_at + lat) / CONTROL_HZ
        self.rows[:, 9] = np.where(present, age, 0.0)

    def _measure(self, rng: np.random.Generator, truth: np.ndarray, hidden: np.ndarray) -> None:
        cfg = self.cfg
        noise_p = rng.normal(0.0, 1.0, (self.n, 3)) * cfg.pose_noise_m + self._bias_p
        noise_y = rng.normal(0.0, 1.0, self.n) * cfg.yaw_noise_rad + self._bias_y
        c, s = math.cos(self._calib_yaw), math.sin(self._calib_yaw)
        for i in range(self.n):
            row = truth[i]
            if row[0] < 0.5 or hidden[i]:
                continue
            q = row[4:8]
            x, y, z = row[1:4]
            seen = np.array([c * x - s * y, s * x + c * y, z]) + self._calib_t
            yaw = yaw_of(q) + self._calib_yaw + noise_y[i]
            if cfg.symmetric_yaw:
                yaw = canonical_yaw(yaw, self._periods[i])
            if cfg.yaw_noise_rad > 0 or cfg.yaw_bias_rad > 0 or cfg.symmetric_yaw \
                    or self._calib_yaw:
                q = with_yaw(q, yaw)
            self.rows[i, :9] = (1.0, *(seen + noise_p[i]), *q,
                                row[8] if cfg.joint_readings else 0.0)
            self._measured_at[i] = self._step
        self._age()

    def _occluded(self, truth: np.ndarray) -> np.ndarray:
        """Rows whose every sample point the gripper hides from every camera."""
        out = np.array([truth[i, 0] >= 0.5 and bool(self._samples[i][1])
                        for i in range(self.n)])
        for cam in self._cams:
            if not out.any():
                break
            out = self._occluded_from(truth, cam, out)
        return out

    def _occluded_from(self, truth: np.ndarray, cam_id: int, rows: np.ndarray) -> np.ndarray:
        """Which of ``rows`` have every sample point hidden by the gripper from camera
        ``cam_id``."""
        import mujoco

        m, d = self.task.s.model, self.task.s.data
        cam = d.cam_xpos[cam_id]
        out = np.zeros(self.n, dtype=bool)
        for i in np.nonzero(rows)[0]:
            kind, ids = self._samples[i]
            if kind == "site":
                points = d.site_xpos[ids]
            else:
                axis = d.geom_xmat[ids].reshape(-1, 3, 3)[:, :, 2]
                reach = (0.8 * m.geom_aabb[ids, 5])[:, None] * axis
                points = np.concatenate([d.geom_xpos[ids], d.geom_xpos[ids] - reach,
                                         d.geom_xpos[ids] + reach])
            blocked = True
            for point in points:
                vec = point + (0.0, 0.0, 0.002) - cam
                dist = mujoco.mj_ray(m, d, cam, vec, RAY_GROUPS, 1, -1, self._geomid)
                geom = int(self._geomid[0])
                hit_hand = geom >= 0 and 0 <= dist < 1.0 and int(m.geom_bodyid[geom]) in self._hand
                if not hit_hand:
                    blocked = False
                    break
            out[i] = blocked
        return out
