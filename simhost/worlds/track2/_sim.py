"""``Sim``: named access to a compiled bench model and a per-step contact summary."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ._bench import HAND_JOINTS, WORKSPACE_HI, WORKSPACE_LO, yaw_of


class Sim:
    """Named access to one model and its data, plus a per-step contact summary."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.model = model
        self.data = data
        j = [model.joint(n) for n in (*HAND_JOINTS, "finger_l", "finger_r")]
        self._qadr = np.array([int(x.qposadr[0]) for x in j])
        self._vadr = np.array([int(x.dofadr[0]) for x in j[:4]])
        self.palm = model.geom("palm").id
        self.finger_geoms = (model.geom("finger_l").id, model.geom("finger_r").id)
        self.hand_geoms = {self.palm, *self.finger_geoms}
        self.left_touch: set[int] = set()
        self.right_touch: set[int] = set()
        self.palm_touch: set[int] = set()
        self.force = np.zeros(6)
        self.max_hand_force = 0.0

    # -- the gripper -------------------------------------------------------------------------
    def ee(self) -> np.ndarray:
        """TCP x, y, z and yaw (the hand's joint positions)."""
        return self.data.qpos[self._qadr[:4]].copy()

    def ee_vel(self) -> np.ndarray:
        """TCP velocity (x, y, z, yaw rate)."""
        return self.data.qvel[self._vadr].copy()

    def width(self) -> float:
        """Finger opening (m)."""
        return float(self.data.qpos[self._qadr[4]] + self.data.qpos[self._qadr[5]])

    def hand_at_limit(self, margin: float = 1e-3) -> bool:
        """Whether a hand joint sits at its range limit."""
        q = self.data.qpos[self._qadr[:4]]
        return bool(np.any(q <= WORKSPACE_LO + margin) or np.any(q >= WORKSPACE_HI - margin))

    # -- bodies and joints ---------------------------------------------------------------------
    def bid(self, name: str) -> int:
        return int(self.model.body(name).id)

    def pos(self, body: int) -> np.ndarray:
        return self.data.xpos[body].copy()

    def quat(self, body: int) -> np.ndarray:
        return self.data.xquat[body].copy()

    def yaw(self, body: int) -> float:
        return yaw_of(self.data.xquat[body])

    def point(self, body: int, local: tuple[float, float, float]) -> np.ndarray:
        """World position of a point given in ``body``'s frame."""
        return self.data.xpos[body] + self.data.xmat[body].reshape(3, 3) @ np.asarray(local)

    def tilt(self, body: int) -> float:
        """Angle between the body's z axis and the world's (rad)."""
        zz = float(self.data.xmat[body][8])
        return math.acos(max(-1.0, min(1.0, zz)))

    def vz(self, body: int) -> float:
        """Vertical velocity of a free body (m/s); 0 for any other body."""
        j = int(self.model.body_jntadr[body])
        if j < 0 or self.model.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE:
            return 0.0
        return float(self.data.qvel[self.model.jnt_dofadr[j] + 2])

    def site(self, site: int) -> np.ndarray:
        """World position of a site."""
        return self.data.site_xpos[site].copy()

    def qpos(self, joint: str) -> float:
        return float(self.data.qpos[self.model.joint(joint).qposadr[0]])

    # -- contacts ------------------------------------------------------------------------------
    def refresh(self) -> None:
        """Summarise the contacts that touch the gripper (call after every step)."""
        m, d = self.model, self.data
        self.left_touch, self.right_touch, self.palm_touch = set(), set(), set()
        f_l = f_r = f_p = 0.0
        net = np.zeros(3)
        fmax = 0.0
        buf = np.zeros(6)
        for i in range(d.ncon):
            c = d.contact[i]
            g1, g2 = int(c.geom1), int(c.geom2)
            if g1 not in self.hand_geoms and g2 not in self.hand_geoms:
                continue
            mujoco.mj_contactForce(m, d, i, buf)
            fn = abs(float(buf[0]))
            fmax = max(fmax, fn)
            world = c.frame.reshape(3, 3).T @ buf[:3]
            mine, other = (g1, g2) if g1 in self.hand_geoms else (g2, g1)
            net += -world if mine == g1 else world
            body = int(m.geom_bodyid[other])
            if mine == self.finger_geoms[0]:
                self.left_touch.add(body)
                f_l += fn
            elif mine == self.finger_geoms[1]:
                self.right_touch.add(body)
                f_r += fn
            else:
                self.palm_touch.add(body)
                f_p += fn
        self.force = np.array([f_l, f_r, f_p, *net])
        self.max_hand_force = fmax

    def grasping(self, body: int) -> bool:
        """Both fingers touch ``body``."""
        return body in self.left_touch and body in self.right_touch

    def touching(self, body: int) -> bool:
        """Some part of the gripper touches ``body``."""
        return body in self.left_touch or body in self.right_touch or body in self.palm_touch
