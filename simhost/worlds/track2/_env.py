"""``BenchEnv``: one Track 2 instance as a ``gymnasium.Env``.

Action ``Box(-1, 1, (5,), float32)``: ``[dx, dy, dz, dyaw, grip]``. The first four move the
hand's control target by at most ``DPOS_MAX`` m / ``DYAW_MAX`` rad per step (kept within
``LEAD_POS`` / ``LEAD_YAW`` of the hand so that pushing force stays bounded); ``grip`` maps
[-1, 1] to a finger opening in [0, ``WIDTH_MAX``] m. A step is ``SUBSTEPS`` physics steps of
``PHYSICS_DT`` (20 Hz control); the control target is ramped across them. Every action is
checked first: a non-finite action is replaced by "hold still" (``info["invalid_action"]``),
values outside [-1, 1] are clipped (``info["action_clipped"]``). NaN never reaches MuJoCo.

The split (``split="dev"``, ``"standard"`` or ``"challenge"``, or an explicit ``config``)
decides what the observation holds (see ``simhost.worlds.track2._config``):

- ``proprio`` (7,): TCP x, y, z (m), yaw (rad), finger opening (m), left / right finger
  contact (0/1). Exact.
- ``parts`` (N, 10): per task-relevant part ``present, x, y, z, qw, qx, qy, qz, joint, age``
  in the family's ``part_names`` order; rows past the instance's parts are zero. On the
  official splits these are noisy, delayed, lower-rate measurements, stale while the gripper
  hides the part, yaw modulo the part's symmetry, and ``joint`` is 0 (not observed); ``age``
  is how old the state shown is (s). Absent when the split is RGB-D only.
- ``force`` (6,): summed normal contact force on the left finger, right finger and palm (N),
  then the net contact force on the gripper in the world frame (N). Exact.
- ``goal`` (4,): ``[stated, g1, g2, g3]`` (``dev`` only): the task's goal parameters.
- ``rgb`` (H, W, 3) uint8, ``depth`` (H, W) float32 metres and, if configured,
  ``segmentation`` (H, W) int32 (0 nothing, k the part of ``parts`` row k - 1, -1 the
  gripper) from the ``overview`` camera (the robot's side, the near half of the bench),
  ``rgb_front``, ``depth_front`` (``segmentation_front``) from the ``front`` camera (across
  the table, the far half) and ``rgb_top``, ``depth_top`` (``segmentation_top``) from the
  ``top`` camera (straight down into the press wells' region; ``CAMERAS``), no shadows,
  rendered when parts are measured.

``reset(seed=...)`` seeds everything random in an episode: the per-reset jitter of part and
fixture poses (``attempt_jitter_*``) and the observation noise. The same instance and seed
give the same episode, bit for bit.

``info``: ``progress`` [0, 1], ``success``, ``stage`` (true key stage or ``"done"``),
``value`` (the magnitude the goal is about: fraction opened, angle turned, depth reached),
``contact_force`` (largest normal contact force on the gripper, N — a firm grasp alone is
up to ``GRIP_FORCE`` = 20 N), ``push_force`` (norm of the net contact force on the gripper,
N), ``sim_warnings`` (MuJoCo warnings raised in this step, plus ``"diverged"`` if the step
had to be undone), ``events`` (state-change annotations of this step, including
``dropped``), ``invalid_action``, ``action_clipped``, ``joint_limit`` (the hand at a range
limit), ``step``.
"""

from __future__ import annotations

import hashlib
import json
import math
import struct
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces

from ._bench import (
    CAMERAS,
    CONTROL_HZ,
    DPOS_MAX,
    DYAW_MAX,
    HOME,
    LEAD_POS,
    LEAD_YAW,
    PART_FIELDS,
    SUBSTEPS,
    WIDTH_MAX,
    WORKSPACE_HI,
    WORKSPACE_LO,
    build_mjcf,
    image_key,
)
from ._camera import BenchCameras
from ._config import BenchConfig, split_config
from ._errors import InstanceParamsError, StateError
from ._families import make_task
from ._family import GOAL_SIZE, Evaluation
from ._info import BenchInfo
from ._observe import PartsChannel, quat_mul, quat_z
from ._params import FAMILIES, InstanceParams, default_source, sample_instance
from ._sim import Sim

_STATE_MAGIC = b"EAGCT2S2"
_STATE_SIG = mujoco.mjtState.mjSTATE_INTEGRATION
_SETTLE_SUBSTEPS = 50
DROP_SPEED = 0.3  # m/s: a loose part falling faster than this, untouched, was dropped
JITTER_CLIP = 2.5  # per-reset offsets are clipped at this many standard deviations
_WARNINGS = [n for n in mujoco.mjtWarning.__members__ if n != "mjNWARNING"]


def instance_id(params: InstanceParams, config: BenchConfig | None = None) -> str:
    """A short fingerprint of an instance and its bench config (sha256 of their JSON)."""
    text = params.model_dump_json() + (config.model_dump_json() if config else "")
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class BenchEnv(gym.Env[dict[str, np.ndarray], np.ndarray]):
    """A Track 2 manipulation instance: table, two-finger gripper and one task family.

    Args:
      params: the instance; if omitted, ``family`` with ``instance_seed`` (sampled around the
        canonical source with the split's variation) or the canonical source itself.
      split: ``"dev"`` (default), ``"standard"`` or ``"challenge"``: the bench config and
        the variation of sampled instances.
      config: the bench config (overrides the split's).
      difficulty: overrides the split's difficulty when sampling with ``instance_seed``.
      render_mode: ``None`` or ``"rgb_array"`` (``render()``: the ``overview`` camera's RGB).
      render_rgbd: add (True) or drop (False) ``rgb`` and ``depth`` whatever the split says.
      image_size: ``(height, width)`` of rendered images (default: the split's).
      max_steps: truncate after this many steps (default: the family's cap).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": CONTROL_HZ}

    def __init__(
        self,
        params: InstanceParams | None = None,
        *,
        family: str | None = None,
        instance_seed: int | None = None,
        split: str = "dev",
        config: BenchConfig | None = None,
        difficulty: float | None = None,
        render_mode: str | None = None,
        render_rgbd: bool | None = None,
        image_size: tuple[int, int] | None = None,
        max_steps: int | None = None,
    ) -> None:
        preset = split_config(split)
        if params is None:
            if family is None:
                raise InstanceParamsError(f"BenchEnv needs params or a family (one of {FAMILIES})")
            params = (
                default_source(family)
                if instance_seed is None
                else sample_instance(family, instance_seed, difficulty=difficulty,
                                     variation=preset.variation)
            )
        elif family is not None and family != params.family:
            raise InstanceParamsError(f"family {family!r} does not match params ({params.family})")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        config = config or preset.bench
        obs_update: dict[str, Any] = {}
        if render_rgbd is not None:
            obs_update["rgbd"] = bool(render_rgbd)
        if image_size is not None:
            obs_update["image_size"] = (int(image_size[0]), int(image_size[1]))
        if obs_update:
            config = config.model_copy(
                update={"observation": config.observation.model_copy(update=obs_update)})
        if not config.observation.parts and not config.observation.rgbd:
            raise InstanceParamsError("an observation without parts needs rgbd=True")
        self.config = config
        self.render_mode = render_mode
        self._max_steps_arg = max_steps
        self._camera: BenchCameras | None = None
        self.episode = 0
        self._load(params)

    @property
    def render_rgbd(self) -> bool:
        return self.config.observation.rgbd

    @property
    def image_size(self) -> tuple[int, int]:
        return self.config.observation.image_size

    # -- building ------------------------------------------------------------------------------
    def _load(self, params: InstanceParams) -> None:
        self.params = params
        self.task = make_task(params, self.config)
        self.xml = build_mjcf(self.task.scene(), surface_friction=params.f("surface"),
                              grip_slip=self.config.grip_slip,
                              image_size=self.config.observation.image_size)
        self.model = mujoco.MjModel.from_xml_string(self.xml)
        self.data = mujoco.MjData(self.model)
        self.sim = Sim(self.model, self.data)
        self.task.bind(self.sim)
        self.channel = PartsChannel(self.task, self.config.observation)
        self.max_steps = self._max_steps_arg or self.task.max_steps
        self._instance = instance_id(params, self.config)
        if self._camera is not None:
            self._camera.close()
            self._camera = None
        m = self.model
        self._groups = [tuple(int(m.body(n).id) for n in g) for g in self.task.jitter_groups()]
        self._nominal = {b: (m.body_pos[b].copy(), m.body_quat[b].copy())
                         for g in self._groups for b in g}
        self._offsets = np.zeros((len(self._groups), 3))
        refs = self.task.row_refs()
        self._seg_rows = {int(g): i + 1 for i, ref in enumerate(refs)
                          if ref and ref[0] == "body"
                          for g in np.nonzero(m.geom_bodyid == ref[1])[0]}
        hand = {int(m.body(b).id) for b in ("hand", "finger_l", "finger_r")}
        self._seg_rows.update({int(g): -1 for g in range(m.ngeom) if m.geom_bodyid[g] in hand})
        cfg = self.config.observation
        n = len(self.task.part_names)
        obs: dict[str, spaces.Space[Any]] = {
            "proprio": spaces.Box(
                np.array([*WORKSPACE_LO, 0.0, 0.0, 0.0], dtype=np.float32),
                np.array([*WORKSPACE_HI, WIDTH_MAX + 0.01, 1.0, 1.0], dtype=np.float32),
                dtype=np.float32,
            ),
        }
        if cfg.parts:
            obs["parts"] = spaces.Box(-4.0, 4.0, (n, len(PART_FIELDS)), np.float32)
        obs["force"] = spaces.Box(
            np.array([0, 0, 0, -500, -500, -500], dtype=np.float32),
            np.full(6, 500.0, dtype=np.float32),
            dtype=np.float32,
        )
        if cfg.goal_vector:
            obs["goal"] = spaces.Box(-10.0, 10.0, (GOAL_SIZE,), np.float32)
        if cfg.rgbd:
            h, w = cfg.image_size
            for cam in CAMERAS:
                obs[image_key("rgb", cam)] = spaces.Box(0, 255, (h, w, 3), np.uint8)
                obs[image_key("depth", cam)] = spaces.Box(0.0, 10.0, (h, w), np.float32)
                if cfg.segmentation:
                    obs[image_key("segmentation", cam)] = spaces.Box(-1, n, (h, w), np.int32)
        self.observation_space = spaces.Dict(obs)
        self.action_space = spaces.Box(-1.0, 1.0, (5,), np.float32)
        self._target = HOME.copy()
        self._width = WIDTH_MAX * 0.9
        self._steps = 0
        self._warn = np.zeros(len(_WARNINGS), dtype=np.int64)
        self._flags: dict[str, bool] = {}
        self._progress = 0.0
        self._images: dict[str, np.ndarray] = {}

    @property
    def control_target(self) -> np.ndarray:
        """The hand's current control target (x, y, z, yaw) — privileged, for experts."""
        return self._target.copy()

    @property
    def steps(self) -> int:
        return self._steps

    # -- gymnasium API ---------------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """``reset_typed`` with gymnasium's plain ``info`` dict."""
        obs, info = self.reset_typed(seed=seed, options=options)
        return obs, info.as_dict()

    def step(
        self, action: np.ndarray
    ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """``step_typed`` with gymnasium's plain ``info`` dict."""
        obs, reward, terminated, truncated, info = self.step_typed(action)
        return obs, reward, terminated, truncated, info.as_dict()

    def reset_typed(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], BenchInfo]:
        """Put the instance back in its initial state (jittered as the config says).

        ``options={"params": InstanceParams}`` switches to another instance first. ``seed``
        seeds ``self.np_random``, which draws this reset's jitter and the observation noise.
        The parts' measurement biases come from ``options["bias_seed"]`` when given (an
        episode keeps its biases over its attempts), else from ``self.np_random``.
        """
        super().reset(seed=seed)
        if options and options.get("params") is not None:
            new = options["params"]
            if not isinstance(new, InstanceParams):
                new = InstanceParams.model_validate(new)
            if new.family != self.params.family:
                raise InstanceParamsError(
                    f"reset(options=...) keeps the family ({self.params.family}); make a new "
                    f"env for {new.family}"
                )
            self._load(new)
        m, d = self.model, self.data
        rng = self.np_random
        raw = rng.normal(0.0, 1.0, (len(self._groups), 3))
        joint_jitter = float(np.clip(rng.normal(0.0, 1.0), -JITTER_CLIP, JITTER_CLIP))
        scale = np.array([self.config.attempt_jitter_m, self.config.attempt_jitter_m,
                          self.config.attempt_jitter_rad])
        self._offsets = np.clip(raw, -JITTER_CLIP, JITTER_CLIP) * scale + 0.0  # no -0.0
        mujoco.mj_resetData(m, d)
        self._apply_offsets()
        self._target = HOME.copy()
        self._width = WIDTH_MAX * 0.9
        self._set_hand_qpos()
        self.task.reset(self.sim, joint_jitter)
        self._write_ctrl(self._target, self._width)
        mujoco.mj_forward(m, d)
        for _ in range(_SETTLE_SUBSTEPS):
            mujoco.mj_step(m, d)
        d.time = 0.0
        self._steps = 0
        self.episode += 1
        self._warn = np.array([d.warning[i].number for i in range(len(_WARNINGS))])
        self.sim.refresh()
        bias_seed = (options or {}).get("bias_seed")
        self.channel.reset(rng, None if bias_seed is None else np.random.default_rng(bias_seed))
        self._images = {}
        if self.render_rgbd:
            self._images = self._render_obs()
        ev = self._evaluate()
        self._flags = dict(ev.flags)
        self._progress = self.task.progress(ev)
        return self._obs(), self._info(ev, [], [], False, False)

    def step_typed(
        self, action: np.ndarray
    ) -> tuple[dict[str, np.ndarray], float, bool, bool, BenchInfo]:
        """One control step (module docstring); the info typed."""
        a, invalid, clipped = self._validate(action)
        m, d = self.model, self.data
        old_target, old_width = self._target.copy(), self._width
        if not invalid:
            q = self.sim.ee()
            lead = np.array([LEAD_POS, LEAD_POS, LEAD_POS, LEAD_YAW])
            t = self._target + a[:4] * np.array([DPOS_MAX, DPOS_MAX, DPOS_MAX, DYAW_MAX])
            t = np.clip(t, q - lead, q + lead)
            self._target = np.clip(t, WORKSPACE_LO, WORKSPACE_HI)
            self._width = float((a[4] + 1.0) / 2.0 * WIDTH_MAX)
        before = np.empty(mujoco.mj_stateSize(m, _STATE_SIG))
        mujoco.mj_getState(m, d, before, _STATE_SIG)
        warnings: list[str] = []
        for k in range(1, SUBSTEPS + 1):
            f = k / SUBSTEPS
            target = old_target + f * (self._target - old_target)
            self._write_ctrl(target, old_width + f * (self._width - old_width))
            mujoco.mj_step(m, d)
        diverged = not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel)))
        if diverged:
            mujoco.mj_setState(m, d, before, _STATE_SIG)
            mujoco.mj_forward(m, d)
            self._target, self._width = old_target, old_width
            warnings.append("diverged")
        self._steps += 1
        counts = np.array([d.warning[i].number for i in range(len(_WARNINGS))])
        warnings += [_WARNINGS[i] for i in np.nonzero(counts > self._warn)[0]]
        self._warn = counts
        self.sim.refresh()
        if self.channel.after_step(self.np_random) and self.render_rgbd:
            self._images = self._render_obs()
        ev = self._evaluate()
        events = self._edges(ev.flags)
        progress = self.task.progress(ev)
        reward = float(progress - self._progress) + (1.0 if ev.success else 0.0)
        self._progress = progress
        terminated = bool(ev.success)
        truncated = bool(diverged or self._steps >= self.max_steps)
        info = self._info(ev, warnings, events, invalid, clipped)
        return self._obs(), reward, terminated, truncated, info

    def render(self) -> np.ndarray | None:  # type: ignore[override]
        if self.render_mode != "rgb_array":
            return None
        return self._render()[0]

    def close(self) -> None:
        if self._camera is not None:
            self._camera.close()
            self._camera = None

    # -- state ---------------------------------------------------------------------------------
    def get_state(self) -> bytes:
        """Everything needed to continue the physics bit-exactly: the physics, the fixtures'
        jitter, the control target and the step count (not the observation channel)."""
        st = np.empty(mujoco.mj_stateSize(self.model, _STATE_SIG))
        mujoco.mj_getState(self.model, self.data, st, _STATE_SIG)
        head = json.dumps(
            {
                "instance": self._instance,
                "steps": self._steps,
                "target": [float(x).hex() for x in self._target],
                "width": float(self._width).hex(),
                "warnings": [int(x) for x in self._warn],
                "offsets": [float(x).hex() for x in self._offsets.ravel()],
            },
            sort_keys=True,
        ).encode()
        return _STATE_MAGIC + struct.pack("<I", len(head)) + head + st.astype("<f8").tobytes()

    def set_state(self, state: bytes) -> None:
        """Restore a state from :meth:`get_state` of this same instance."""
        if not isinstance(state, bytes | bytearray) or not state.startswith(_STATE_MAGIC):
            raise StateError("not a bench state (missing the EAGCT2S2 header)")
        try:
            (n,) = struct.unpack_from("<I", state, len(_STATE_MAGIC))
            start = len(_STATE_MAGIC) + 4
            head = json.loads(state[start : start + n])
            arr = np.frombuffer(state[start + n :], dtype="<f8").astype(np.float64)
            target = np.array([float.fromhex(x) for x in head["target"]])
            width = float.fromhex(head["width"])
            steps, warn = int(head["steps"]), np.array(head["warnings"], dtype=np.int64)
            offsets = np.array([float.fromhex(x) for x in head["offsets"]]).reshape(-1, 3)
        except (struct.error, ValueError, KeyError, TypeError) as exc:
            raise StateError(f"corrupt bench state: {exc}") from exc
        if head["instance"] != self._instance:
            raise StateError(
                f"state belongs to instance {head['instance']}, this env is {self._instance}"
            )
        if (arr.size != mujoco.mj_stateSize(self.model, _STATE_SIG) or target.shape != (4,)
                or offsets.shape != self._offsets.shape):
            raise StateError("state size does not match this model")
        self._offsets = offsets
        self._apply_offsets(static_only=True)
        mujoco.mj_setState(self.model, self.data, arr, _STATE_SIG)
        mujoco.mj_forward(self.model, self.data)
        self._target, self._width, self._steps, self._warn = target, width, steps, warn
        self.sim.refresh()
        ev = self._evaluate()
        self._flags = dict(ev.flags)
        self._progress = self.task.progress(ev)

    def state_hash(self) -> str:
        """sha256 of :meth:`get_state` (hex)."""
        return hashlib.sha256(self.get_state()).hexdigest()

    def evaluate(self) -> tuple[Evaluation, float]:
        """The task's reading of the current state and its progress (no stepping)."""
        ev = self._evaluate()
        return ev, self.task.progress(ev)

    # -- internals -----------------------------------------------------------------------------
    def _apply_offsets(self, static_only: bool = False) -> None:
        """Move each jitter group by its offset, about its first body's nominal position."""
        m, d = self.model, self.data
        for group, (dx, dy, dyaw) in zip(self._groups, self._offsets, strict=True):
            pivot = self._nominal[group[0]][0][:2]
            c, s = math.cos(dyaw), math.sin(dyaw)
            turn = quat_z(float(dyaw))
            for b in group:
                pos, quat = self._nominal[b]
                rel = pos[:2] - pivot
                xy = pivot + np.array([c * rel[0] - s * rel[1], s * rel[0] + c * rel[1]])
                xy = xy + (dx, dy)
                j = int(m.body_jntadr[b])
                if j >= 0 and m.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
                    if not static_only:
                        a = int(m.jnt_qposadr[j])
                        d.qpos[a : a + 2] = xy
                        d.qpos[a + 3 : a + 7] = quat_mul(turn, quat)
                    continue
                m.body_pos[b] = (xy[0], xy[1], pos[2])
                m.body_quat[b] = quat_mul(turn, quat)

    def _evaluate(self) -> Evaluation:
        """The task's evaluation plus ``dropped:<part>`` for loose parts falling freely."""
        ev = self.task.evaluate()
        s = self.sim
        for name, body in self.task.loose_parts().items():
            ev.flags[f"dropped:{name}"] = not s.touching(body) and s.vz(body) < -DROP_SPEED
        return ev

    def _validate(self, action: Any) -> tuple[np.ndarray, bool, bool]:
        try:
            a = np.asarray(action, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"action must be 5 numbers [dx, dy, dz, dyaw, grip]: {exc}") from exc
        if a.shape != (5,):
            raise ValueError(f"action must have shape (5,) [dx, dy, dz, dyaw, grip], got {a.shape}")
        if not np.all(np.isfinite(a)):
            return np.zeros(5), True, False
        clipped = bool(np.any(np.abs(a) > 1.0))
        return np.clip(a, -1.0, 1.0), False, clipped

    def _set_hand_qpos(self) -> None:
        adr = self.sim._qadr
        self.data.qpos[adr[:4]] = self._target
        self.data.qpos[adr[4:]] = self._width / 2

    def _write_ctrl(self, target: np.ndarray, width: float) -> None:
        c = self.data.ctrl
        c[:4] = target
        c[4] = c[5] = width / 2

    def _edges(self, flags: dict[str, bool]) -> list[dict[str, str]]:
        out = []
        for key, now in flags.items():
            was = self._flags.get(key, False)
            if now == was:
                continue
            event, part = key.split(":", 1)
            if now:
                out.append({"event": event, "part": part})
            elif event == "grasped":
                out.append({"event": "released", "part": part})
        self._flags = dict(flags)
        return out

    def _obs(self) -> dict[str, np.ndarray]:
        s = self.sim
        space = self.observation_space.spaces
        prop = np.array([*s.ee(), s.width(), float(bool(s.left_touch)), float(bool(s.right_touch))])
        out = {"proprio": np.clip(prop, space["proprio"].low, space["proprio"].high)}
        if "parts" in space:
            out["parts"] = np.clip(self.channel.rows, -4.0, 4.0)
        out["force"] = np.clip(s.force, space["force"].low, space["force"].high)
        if "goal" in space:
            out["goal"] = np.clip(self.task.goal(), -10.0, 10.0)
        obs = {k: v.astype(np.float32) for k, v in out.items()}
        obs.update({k: v.copy() for k, v in self._images.items()})
        return obs

    def _render_obs(self) -> dict[str, np.ndarray]:
        seg_on = self.config.observation.segmentation
        out = {}
        for cam in CAMERAS:
            rgb, depth, seg = self._render(depth=True, segmentation=seg_on, camera=cam)
            out[image_key("rgb", cam)] = rgb
            out[image_key("depth", cam)] = np.clip(depth, 0.0, 10.0).astype(np.float32)
            if seg_on:
                out[image_key("segmentation", cam)] = seg
        return out

    def _render(self, depth: bool = False, segmentation: bool = False,
                camera: str = CAMERAS[0]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One camera's RGB, depth (with ``depth``) and part segmentation (with
        ``segmentation``; 0 nothing, k row k - 1, -1 the gripper)."""
        if self._camera is None:
            h, w = self.image_size
            self._camera = BenchCameras(self.model, h, w, CAMERAS)
        cam = self._camera
        rgb, dep = cam.rgbd(self.data, depth=depth, camera=camera)
        seg = np.zeros(0, dtype=np.int32)
        if segmentation:
            ids = cam.segmentation(self.data, camera=camera)
            lut = np.zeros(self.model.ngeom + 1, dtype=np.int32)
            for g, row in self._seg_rows.items():
                lut[g] = row
            seg = np.where(ids >= 0, lut[np.clip(ids, 0, self.model.ngeom)], 0)
            seg = seg.astype(np.int32)
        return rgb, dep, seg

    def _info(
        self,
        ev: Evaluation,
        warnings: list[str],
        events: list[dict[str, str]],
        invalid: bool,
        clipped: bool,
    ) -> BenchInfo:
        return BenchInfo(
            progress=float(self._progress),
            success=bool(ev.success),
            stage="done" if ev.success else ev.stage,
            value=ev.value,
            contact_force=float(self.sim.max_hand_force),
            push_force=float(np.linalg.norm(self.sim.force[3:])),
            sim_warnings=warnings,
            events=events,
            invalid_action=invalid,
            action_clipped=clipped,
            joint_limit=self.sim.hand_at_limit(),
            step=self._steps,
        )
