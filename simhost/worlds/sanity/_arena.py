"""The sanity arena: a point robot in a walled square must find and reach a target.

Small on purpose (pipeline tests stay fast) but real: MuJoCo physics with contacts, a
sensing radius, and a perturbation (the target moves) that the track uses as its exception.
With ``render_rgbd=True`` the observation also carries the overhead camera's images under
the names every track uses: ``rgb`` (H×W×3 uint8), ``depth`` (H×W float32, metres from the
camera, ``MAX_DEPTH`` where nothing is seen) and ``segmentation`` (H×W int32: the geom id,
``ngeom`` + site id for the target, -1 for background).
"""

from __future__ import annotations

import hashlib
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

HALF = 2.0  # the arena spans [-HALF, HALF]² metres
SENSE_RADIUS = 1.2
REACH_RADIUS = 0.15
MAX_SPEED = 1.0  # m/s at |action| = 1
CONTROL_DT = 0.1
MAX_DEPTH = 20.0  # m: depth where the overhead camera sees nothing
TIMESTEP = 0.01

_XML = """
<mujoco model="eagc-sanity">
  <option timestep="{dt}" integrator="implicitfast">
    <flag warmstart="enable"/>
  </option>
  <visual><quality shadowsize="0" offsamples="0"/></visual>
  <worldbody>
    <light pos="0 0 4" dir="0 0 -1" castshadow="false"/>
    <geom name="floor" type="plane" size="{h} {h} 0.1" rgba=".85 .85 .8 1"/>
    <geom name="wall_n" type="box" pos="0 {w} 0.2" size="{h} 0.05 0.2" rgba=".4 .4 .45 1"/>
    <geom name="wall_s" type="box" pos="0 -{w} 0.2" size="{h} 0.05 0.2" rgba=".4 .4 .45 1"/>
    <geom name="wall_e" type="box" pos="{w} 0 0.2" size="0.05 {h} 0.2" rgba=".4 .4 .45 1"/>
    <geom name="wall_w" type="box" pos="-{w} 0 0.2" size="0.05 {h} 0.2" rgba=".4 .4 .45 1"/>
    <body name="robot" pos="0 0 0.1">
      <joint name="x" type="slide" axis="1 0 0" damping="0.5"/>
      <joint name="y" type="slide" axis="0 1 0" damping="0.5"/>
      <geom name="robot" type="sphere" size="0.1" mass="1" rgba=".2 .4 .9 1"/>
    </body>
    <site name="target" pos="0 0 0.02" size="0.08" type="cylinder" rgba=".9 .2 .2 1"/>
    <camera name="top" pos="0 0 6" xyaxes="1 0 0 0 1 0"/>
  </worldbody>
  <actuator>
    <velocity name="vx" joint="x" kv="20" ctrlrange="-{v} {v}"/>
    <velocity name="vy" joint="y" kv="20" ctrlrange="-{v} {v}"/>
  </actuator>
</mujoco>
"""


def arena_xml() -> str:
    return _XML.format(dt=TIMESTEP, h=HALF + 0.05, w=HALF + 0.05, v=MAX_SPEED)


def sample_point(rng: np.random.Generator, *, margin: float = 0.3) -> np.ndarray:
    return rng.uniform(-HALF + margin, HALF - margin, size=2)


class SanityArenaEnv(gym.Env[dict[str, np.ndarray], np.ndarray]):
    """Gymnasium env: observation dict of float32 boxes, action = velocity in [-1, 1]²."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": int(1 / CONTROL_DT)}

    def __init__(
        self,
        render_mode: str | None = None,
        *,
        render_rgbd: bool = False,
        image_size: tuple[int, int] = (64, 64),
    ) -> None:
        self.model = mujoco.MjModel.from_xml_string(arena_xml())
        self.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
        self.data = mujoco.MjData(self.model)
        self._robot_geom = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, "robot")
        self._walls = {
            mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, f"wall_{s}") for s in "nsew"
        }
        self._target_site = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, "target")
        self._substeps = round(CONTROL_DT / TIMESTEP)
        self.render_mode = render_mode
        self._renderer: mujoco.Renderer | None = None
        self.render_rgbd = render_rgbd
        self.image_size = (int(image_size[0]), int(image_size[1]))  # width, height
        self._camera: mujoco.Renderer | None = None
        box = gym.spaces.Box
        spaces: dict[str, gym.Space[Any]] = {
            "position": box(-HALF, HALF, (2,), np.float32),
            "velocity": box(-5.0, 5.0, (2,), np.float32),
            "target_visible": box(0.0, 1.0, (1,), np.float32),
            "target_rel": box(-2 * HALF, 2 * HALF, (2,), np.float32),
        }
        if render_rgbd:
            w, h = self.image_size
            spaces["rgb"] = box(0, 255, (h, w, 3), np.uint8)
            spaces["depth"] = box(0.0, MAX_DEPTH, (h, w), np.float32)
            n_ids = self.model.ngeom + self.model.nsite
            spaces["segmentation"] = box(-1, n_ids - 1, (h, w), np.int32)
        self.observation_space = gym.spaces.Dict(spaces)
        self.action_space = box(-1.0, 1.0, (2,), np.float32)
        self.target = np.zeros(2)
        self.collisions = 0
        self.path_length = 0.0
        self.sim_warnings = 0

    # ------------------------------------------------------------------ gymnasium
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        super().reset(seed=seed)
        options = options or {}
        mujoco.mj_resetData(self.model, self.data)
        start = np.asarray(options.get("start", sample_point(self.np_random)), dtype=float)
        target = options.get("target")
        if target is None:
            target = sample_point(self.np_random)
            while np.linalg.norm(target - start) < 1.5:
                target = sample_point(self.np_random)
        self.data.qpos[:2] = start
        self.move_target(np.asarray(target, dtype=float))
        mujoco.mj_forward(self.model, self.data)
        self.collisions = 0
        self.path_length = 0.0
        self.sim_warnings = 0
        return self._obs(), self._info()

    def step(
        self, action: np.ndarray
    ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        a = np.asarray(action, dtype=np.float64).reshape(2)
        a = np.where(np.isfinite(a), a, 0.0)  # NaN/Inf never reach MuJoCo
        self.data.ctrl[:] = np.clip(a, -1.0, 1.0) * MAX_SPEED
        before = self.position.copy()
        touching = False
        for _ in range(self._substeps):
            mujoco.mj_step(self.model, self.data)
            touching = touching or self._touching_wall()
        self.collisions += int(touching)
        self.path_length += float(np.linalg.norm(self.position - before))
        warnings = int(sum(w.number for w in self.data.warning))
        if warnings:
            self.sim_warnings += warnings
            self.data.warning.number[:] = 0  # type: ignore[index]
        dist = self.distance_to_target()
        reached = dist < REACH_RADIUS
        return self._obs(), -dist, bool(reached), False, self._info()

    def render(self) -> np.ndarray | None:
        if self._renderer is None:
            self._renderer = mujoco.Renderer(self.model, 240, 240)
        self._renderer.update_scene(self.data, camera="top")
        return self._renderer.render()

    def close(self) -> None:
        for r in (self._renderer, self._camera):
            if r is not None:
                r.close()
        self._renderer = self._camera = None

    # --------------------------------------------------------- world (for the plugin)
    @property
    def position(self) -> np.ndarray:
        return self.data.qpos[:2].copy()

    def distance_to_target(self) -> float:
        return float(np.linalg.norm(self.position - self.target))

    def move_target(self, xy: np.ndarray) -> None:
        """Perturbation: put the target somewhere else."""
        self.target = np.asarray(xy, dtype=float).copy()
        self.model.site_pos[self._target_site, :2] = self.target

    def target_visible(self) -> bool:
        return self.distance_to_target() <= SENSE_RADIUS

    def ground_truth(self) -> dict[str, Any]:
        return {
            "target": self.target.tolist(),
            "robot": self.position.tolist(),
            "arena_half": HALF,
        }

    def get_state(self) -> bytes:
        spec = mujoco.mjtState.mjSTATE_INTEGRATION
        state = np.empty(mujoco.mj_stateSize(self.model, spec))
        mujoco.mj_getState(self.model, self.data, state, spec)
        return state.tobytes() + self.target.tobytes()

    def set_state(self, blob: bytes) -> None:
        spec = mujoco.mjtState.mjSTATE_INTEGRATION
        arr = np.frombuffer(blob, dtype=np.float64)
        mujoco.mj_setState(self.model, self.data, arr[:-2].copy(), spec)
        self.move_target(arr[-2:])
        mujoco.mj_forward(self.model, self.data)

    def state_hash(self) -> str:
        return hashlib.blake2b(self.get_state(), digest_size=8).hexdigest()

    # ------------------------------------------------------------------ internals
    def _touching_wall(self) -> bool:
        for i in range(self.data.ncon):
            c = self.data.contact[i]
            pair = {int(c.geom1), int(c.geom2)}
            if self._robot_geom in pair and pair & self._walls:
                return True
        return False

    def _obs(self) -> dict[str, np.ndarray]:
        visible = self.target_visible()
        rel = (self.target - self.position) if visible else np.zeros(2)
        obs = {
            "position": self.position.astype(np.float32),
            "velocity": np.clip(self.data.qvel[:2], -5, 5).astype(np.float32),
            "target_visible": np.array([float(visible)], dtype=np.float32),
            "target_rel": rel.astype(np.float32),
        }
        if self.render_rgbd:
            obs["rgb"], obs["depth"], obs["segmentation"] = self._render_rgbd()
        return obs

    def _render_rgbd(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The overhead camera: colour, depth (m) and segmentation, on the calling thread."""
        w, h = self.image_size
        if self._camera is None:
            self._camera = mujoco.Renderer(self.model, h, w)
        r = self._camera
        r.update_scene(self.data, camera="top")
        rgb = r.render().copy()
        r.enable_depth_rendering()
        depth = np.minimum(r.render(), MAX_DEPTH).astype(np.float32)
        r.disable_depth_rendering()
        r.enable_segmentation_rendering()
        seg = r.render()
        r.disable_segmentation_rendering()
        ids, types = seg[..., 0], seg[..., 1]
        out = np.full((h, w), -1, np.int32)
        geom = types == int(mujoco.mjtObj.mjOBJ_GEOM)
        site = types == int(mujoco.mjtObj.mjOBJ_SITE)
        out[geom] = ids[geom]
        out[site] = self.model.ngeom + ids[site]
        return rgb, depth, out

    def _info(self) -> dict[str, Any]:
        return {"collisions": self.collisions, "sim_warnings": self.sim_warnings}
