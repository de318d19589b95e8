"""The view an agent acts through, and motion primitives closed on the observations.

``View`` keeps a :class:`~perception.Perception` of the part rows, the exact proprioception
and a mirror of the hand's control target (the bench moves the target by the action, keeps
it within ``LEAD`` of the hand and inside the workspace: mirroring that makes a move land
where it is aimed). The primitives (``move``, ``hold``, ``grip``, ``pick``, ``servo``,
``release``, ``look``) are generators of actions ``[dx, dy, dz, dyaw, grip]``. The facts
used here are the public ones of the track README: per-step limits, the hand's lead, the
workspace, the gripper's opening. The controllers that use them are in ``generic.py``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from perception import Perception, wrap

DPOS, DYAW, WMAX = 0.015, 0.15, 0.09
LEAD = np.array([0.02, 0.02, 0.02, 0.3])
LO = np.array([-0.30, -0.30, 0.003, -3.2])
HI = np.array([0.30, 0.30, 0.30, 3.2])
Plan = Iterator[np.ndarray]



def nearest_yaw(yaw: float, period: float, near: float = 0.0) -> float:
    return near + (yaw - near + period / 2) % period - period / 2


class View:
    """Perception, the exact proprioception, and a mirror of the hand's control target."""

    def __init__(self, rows: int, movable: set[int], reach: dict[int, float],
                 links: dict[int, int]) -> None:
        """``movable``: rows the hand may carry or drive; ``reach``: how far from the hand a
        held row's frame may sit; ``links``: rows rigid with another (a tool's tip)."""
        self.p = Perception(rows, movable, reach, links)
        self.obs: dict[str, np.ndarray] = {}
        self.prev_ee = np.zeros(4)
        self.target = np.zeros(4)

    def update(self, obs: dict[str, Any], *, reset: bool = False) -> None:
        self.prev_ee = self.ee() if self.obs and not reset else np.asarray(obs["proprio"][:4])
        self.obs = {k: np.asarray(v, dtype=float) for k, v in obs.items()
                    if isinstance(v, np.ndarray) and k in ("proprio", "parts", "force")}
        self.p.update(self.obs)
        if reset:
            self.target = self.ee().copy()

    def ee(self) -> np.ndarray:
        return self.obs["proprio"][:4].copy()

    def width(self) -> float:
        return float(self.obs["proprio"][4])

    def speed(self) -> float:
        return float(np.linalg.norm(self.ee()[:2] - self.prev_ee[:2])) * 20.0

    def pos(self, i: int) -> np.ndarray:
        return self.p.pos(i)

    def yaw(self, i: int) -> float:
        return self.p.yaw(i)

    def present(self, i: int) -> bool:
        return bool(self.p.present[i])

    def command(self, goal: Any, yaw: float, width: float, speed: float = 1.0) -> np.ndarray:
        goal = np.clip(np.asarray(goal, dtype=float), LO[:3], HI[:3])
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


def grip(v: View, width: float, steps: int = 6) -> Plan:
    """Close, or open gently (6 mm per step), and wait."""
    now = v.width()
    if width > now + 0.006:
        for w in np.arange(now + 0.006, width, 0.006):
            yield v.command(v.target[:3], v.target[3], float(w))
    yield from hold(v, steps, width)


def pick(v: View, top: np.ndarray, yaw: float, open_w: float, depth: float, lift: float) -> Plan:
    yield from move(v, [top[0], top[1], top[2] + 0.04], yaw, open_w, tol=0.004)
    yield from move(v, [top[0], top[1], top[2] - depth], yaw, open_w, speed=0.6)
    yield from grip(v, 0.0, 6)
    ee = v.ee()
    yield from move(v, [ee[0], ee[1], lift], yaw, 0.0, tol=0.004)


def servo(v: View, error: Callable[[], tuple[np.ndarray, float]], z: float, *,
          tol: float = 0.0008, yaw_tol: float = 0.02, max_steps: int = 40) -> Plan:
    for _ in range(max_steps):
        err, yaw_err = error()
        ee = v.ee()
        if np.linalg.norm(err) < tol and abs(yaw_err) < yaw_tol and v.speed() < 0.003:
            return
        yield from move(v, [ee[0] + err[0], ee[1] + err[1], z], ee[3] + yaw_err, 0.0,
                        max_steps=1)


def release(v: View, open_w: float, up: float) -> Plan:
    yield from grip(v, open_w, 6)
    ee = v.ee()
    yield from move(v, [ee[0], ee[1], ee[2] + up], ee[3], open_w, tol=0.005)


def look(v: View, steps: int = 8) -> Plan:
    """Hold still while measurements accumulate."""
    yield from hold(v, steps, v.width())
