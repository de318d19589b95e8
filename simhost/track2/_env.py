"""``BenchEnv``: one Track 2 instance as a ``gymnasium.Env``.

Action ``Box(-1, 1, (5,), float32)``: ``[dx, dy, dz, dyaw, grip]``. The first four move the
hand's control target by at most ``DPOS_MAX`` m / ``DYAW_MAX`` rad per step (kept within
``LEAD_POS`` / ``LEAD_YAW`` of the hand so that pushing force stays bounded); ``grip`` maps
[-1, 1] to a finger opening in [0, ``WIDTH_MAX``] m. A step is ``SUBSTEPS`` physics steps of
``PHYSICS_DT`` (20 Hz control); the control target is ramped across them. Every action is
checked first: a non-finite action is replaced by "hold still" (``info["invalid_action"]``),
values outside [-1, 1] are clipped (``info["action_clipped"]``). NaN never reaches MuJoCo.

Observation ``Dict``:

- ``proprio`` (7,): TCP x, y, z, yaw, finger opening, left / right finger contact (0/1).
- ``parts`` (N, 9): per task-relevant part ``present, x, y, z, qw, qx, qy, qz, joint``
  (``joint``: the hinge angle or slide position of an articulated part); family order in
  each family's ``part_names``; rows past the instance's parts are zero.
- ``force`` (6,): summed normal contact force on the left finger, right finger and palm (N),
  then the net contact force on the gripper in the world frame (N).
- ``goal`` (4,): ``[stated, g1, g2, g3]``; zeros when the task states no goal.
- with ``render_rgbd=True``: ``rgb`` (H, W, 3) uint8 and ``depth`` (H, W, 1) float32 metres
  from the ``overview`` camera (no shadows, no multisampling).

``info``: ``progress`` [0, 1], ``success``, ``stage`` (true key stage or ``"done"``),
``contact_force`` (largest normal contact force on the gripper, N — a firm grasp alone is
up to ``GRIP_FORCE`` = 20 N), ``push_force`` (norm of the net contact force on the gripper, N:
what it pushes with, the squeeze cancelling out), ``sim_warnings`` (MuJoCo warnings raised in
this step, plus ``"diverged"`` if the step had to be undone), ``events`` (state-change
annotations of this step, including ``dropped``), ``invalid_action``, ``action_clipped``,
``joint_limit`` (the hand at a range limit), ``step``.
"""

from __future__ import annotations

import hashlib
import json
import struct
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces

from ._bench import (
    CONTROL_HZ,
    DPOS_MAX,
    DYAW_MAX,
    HOME,
    LEAD_POS,
    LEAD_YAW,
    SUBSTEPS,
    WIDTH_MAX,
    WORKSPACE_HI,
    WORKSPACE_LO,
    build_mjcf,
)
from ._errors import InstanceParamsError, StateError
from ._families import make_task
from ._family import GOAL_SIZE, PART_FIELDS, Evaluation
from ._params import FAMILIES, InstanceParams, default_source, sample_instance
from ._sim import Sim

_STATE_MAGIC = b"EAGCT2S1"
_STATE_SIG = mujoco.mjtState.mjSTATE_INTEGRATION
_SETTLE_SUBSTEPS = 50
DROP_SPEED = 0.3  # m/s: a loose part falling faster than this, untouched, was dropped
_WARNINGS = [n for n in mujoco.mjtWarning.__members__ if n != "mjNWARNING"]


def instance_id(params: InstanceParams) -> str:
    """A short fingerprint of an instance (sha256 of its JSON)."""
    return hashlib.sha256(params.model_dump_json().encode()).hexdigest()[:16]


class BenchEnv(gym.Env[dict[str, np.ndarray], np.ndarray]):
    """A Track 2 manipulation instance: table, two-finger gripper and one task family.

    Args:
      params: the instance; if omitted, ``family`` with ``instance_seed`` (sampled around the
        canonical source at ``difficulty``) or the canonical source itself.
      render_mode: ``None`` or ``"rgb_array"``.
      render_rgbd: add ``rgb`` and ``depth`` to the observation.
      image_size: ``(height, width)`` of rendered images.
      max_steps: truncate after this many steps (default: the family's cap).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": CONTROL_HZ}

    def __init__(
        self,
        params: InstanceParams | None = None,
        *,
        family: str | None = None,
        instance_seed: int | None = None,
        difficulty: float = 0.5,
        render_mode: str | None = None,
        render_rgbd: bool = False,
        image_size: tuple[int, int] = (120, 160),
        max_steps: int | None = None,
    ) -> None:
        if params is None:
            if family is None:
                raise InstanceParamsError(f"BenchEnv needs params or a family (one of {FAMILIES})")
            params = (
                default_source(family)
                if instance_seed is None
                else sample_instance(family, instance_seed, difficulty=difficulty)
            )
        elif family is not None and family != params.family:
            raise InstanceParamsError(f"family {family!r} does not match params ({params.family})")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.render_mode = render_mode
        self.render_rgbd = render_rgbd
        self.image_size = (int(image_size[0]), int(image_size[1]))
        self._max_steps_arg = max_steps
        self._renderer: mujoco.Renderer | None = None
        self.episode = 0
        self._load(params)

    # -- building ------------------------------------------------------------------------------
    def _load(self, params: InstanceParams) -> None:
        self.params = params
        self.task = make_task(params)
        self.xml = build_mjcf(self.task.scene(), surface_friction=params.f("surface"))
        self.model = mujoco.MjModel.from_xml_string(self.xml)
        self.data = mujoco.MjData(self.model)
        self.sim = Sim(self.model, self.data)
        self.task.bind(self.sim)
        self.max_steps = self._max_steps_arg or self.task.max_steps
        self._instance = instance_id(params)
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        n = len(self.task.part_names)
        obs: dict[str, spaces.Space[Any]] = {
            "proprio": spaces.Box(
                np.array([*WORKSPACE_LO, 0.0, 0.0, 0.0], dtype=np.float32),
                np.array([*WORKSPACE_HI, WIDTH_MAX + 0.01, 1.0, 1.0], dtype=np.float32),
                dtype=np.float32,
            ),
            "parts": spaces.Box(-4.0, 4.0, (n, len(PART_FIELDS)), np.float32),
            "force": spaces.Box(
                np.array([0, 0, 0, -500, -500, -500], dtype=np.float32),
                np.full(6, 500.0, dtype=np.float32),
                dtype=np.float32,
            ),
            "goal": spaces.Box(-10.0, 10.0, (GOAL_SIZE,), np.float32),
        }
        if self.render_rgbd:
            h, w = self.image_size
            obs["rgb"] = spaces.Box(0, 255, (h, w, 3), np.uint8)
            obs["depth"] = spaces.Box(0.0, 10.0, (h, w, 1), np.float32)
        self.observation_space = spaces.Dict(obs)
        self.action_space = spaces.Box(-1.0, 1.0, (5,), np.float32)
        self._target = HOME.copy()
        self._width = WIDTH_MAX * 0.9
        self._steps = 0
        self._warn = np.zeros(len(_WARNINGS), dtype=np.int64)
        self._flags: dict[str, bool] = {}
        self._progress = 0.0

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
        """Put the instance back in its initial state.

        ``options={"params": InstanceParams}`` switches to another instance first. The
        initial state depends on the instance only; ``seed`` seeds ``self.np_random``.
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
        mujoco.mj_resetData(m, d)
        self._target = HOME.copy()
        self._width = WIDTH_MAX * 0.9
        self._set_hand_qpos()
        self.task.reset(self.sim)
        self._write_ctrl(self._target, self._width)
        mujoco.mj_forward(m, d)
        for _ in range(_SETTLE_SUBSTEPS):
            mujoco.mj_step(m, d)
        d.time = 0.0
        self._steps = 0
        self.episode += 1
        self._warn = np.array([d.warning[i].number for i in range(len(_WARNINGS))])
        self.sim.refresh()
        ev = self._evaluate()
        self._flags = dict(ev.flags)
        self._progress = self.task.progress(ev)
        return self._obs(), self._info(ev, [], [], False, False)

    def step(
        self, action: np.ndarray
    ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
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
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # -- state ---------------------------------------------------------------------------------
    def get_state(self) -> bytes:
        """Everything needed to continue bit-exactly: physics, control target, step count."""
        st = np.empty(mujoco.mj_stateSize(self.model, _STATE_SIG))
        mujoco.mj_getState(self.model, self.data, st, _STATE_SIG)
        head = json.dumps(
            {
                "instance": self._instance,
                "steps": self._steps,
                "target": [float(x).hex() for x in self._target],
                "width": float(self._width).hex(),
                "warnings": [int(x) for x in self._warn],
            },
            sort_keys=True,
        ).encode()
        return _STATE_MAGIC + struct.pack("<I", len(head)) + head + st.astype("<f8").tobytes()

    def set_state(self, state: bytes) -> None:
        """Restore a state from :meth:`get_state` of this same instance."""
        if not isinstance(state, bytes | bytearray) or not state.startswith(_STATE_MAGIC):
            raise StateError("not a bench state (missing the EAGCT2S1 header)")
        try:
            (n,) = struct.unpack_from("<I", state, len(_STATE_MAGIC))
            start = len(_STATE_MAGIC) + 4
            head = json.loads(state[start : start + n])
            arr = np.frombuffer(state[start + n :], dtype="<f8").astype(np.float64)
            target = np.array([float.fromhex(x) for x in head["target"]])
            width = float.fromhex(head["width"])
            steps, warn = int(head["steps"]), np.array(head["warnings"], dtype=np.int64)
        except (struct.error, ValueError, KeyError, TypeError) as exc:
            raise StateError(f"corrupt bench state: {exc}") from exc
        if head["instance"] != self._instance:
            raise StateError(
                f"state belongs to instance {head['instance']}, this env is {self._instance}"
            )
        if arr.size != mujoco.mj_stateSize(self.model, _STATE_SIG) or target.shape != (4,):
            raise StateError("state size does not match this model")
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
        prop = np.array([*s.ee(), s.width(), float(bool(s.left_touch)), float(bool(s.right_touch))])
        space = self.observation_space.spaces
        obs = {
            "proprio": np.clip(prop, space["proprio"].low, space["proprio"].high),
            "parts": np.clip(self.task.parts(), -4.0, 4.0),
            "force": np.clip(s.force, space["force"].low, space["force"].high),
            "goal": np.clip(self.task.goal(), -10.0, 10.0),
        }
        out = {k: v.astype(np.float32) for k, v in obs.items()}
        if self.render_rgbd:
            rgb, depth = self._render(depth=True)
            out["rgb"] = rgb
            out["depth"] = np.clip(depth, 0.0, 10.0).astype(np.float32)[..., None]
        return out

    def _render(self, depth: bool = False) -> tuple[np.ndarray, np.ndarray]:
        if self._renderer is None:
            h, w = self.image_size
            self._renderer = mujoco.Renderer(self.model, h, w)
            flags = self._renderer.scene.flags
            flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
            flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        r = self._renderer
        r.update_scene(self.data, camera="overview")
        rgb = r.render().copy()
        dep = np.zeros(0, dtype=np.float32)
        if depth:
            r.enable_depth_rendering()
            r.update_scene(self.data, camera="overview")
            dep = r.render().copy()
            r.disable_depth_rendering()
        return rgb, dep

    def _info(
        self,
        ev: Evaluation,
        warnings: list[str],
        events: list[dict[str, str]],
        invalid: bool,
        clipped: bool,
    ) -> dict[str, Any]:
        return {
            "progress": float(self._progress),
            "success": bool(ev.success),
            "stage": "done" if ev.success else ev.stage,
            "contact_force": float(self.sim.max_hand_force),
            "push_force": float(np.linalg.norm(self.sim.force[3:])),
            "sim_warnings": warnings,
            "events": events,
            "invalid_action": invalid,
            "action_clipped": clipped,
            "joint_limit": self.sim.hand_at_limit(),
            "step": self._steps,
        }


def register_envs() -> list[str]:
    """Register ``eagc/Bench-<Family>-v0`` for every family; returns the ids (idempotent)."""
    ids = []
    for fam in FAMILIES:
        env_id = f"eagc/Bench-{fam.title().replace('_', '')}-v0"
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point="simhost.track2._env:BenchEnv",
                kwargs={"family": fam},
                disable_env_checker=False,
            )
        ids.append(env_id)
    return ids
