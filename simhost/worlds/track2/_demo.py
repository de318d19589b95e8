"""``write_demo_packet``: run the scripted expert on a source instance, write the packet.

The format is ``schemas.DemoManifest`` (``eagc-demo/v2``). The expert is the privileged one
(a demonstrator knows what it is doing); the observations it leaves in the packet are the
ones its robot made through the split's observation channel.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from schemas import Annotation, ArraySpec, DemoManifest, FrameSpec, KeyStage
from simhost.host._png import encode_png

from ._bench import (
    ACTION_NAMES,
    CONTROL_HZ,
    DPOS_MAX,
    DYAW_MAX,
    FORCE_NAMES,
    PART_FIELDS,
    PROPRIO_NAMES,
    WIDTH_MAX,
)
from ._config import BenchConfig
from ._env import BenchEnv
from ._errors import DemoPacketError
from ._expert import ScriptedExpert
from ._family import GOAL_NAMES, action, move
from ._packet import OBS_KEYS
from ._params import InstanceParams

POST_STEPS = 24
"""After the goal an official split's demonstration (annotations without magnitudes) goes on
this many steps (1.2 s): the demonstrator draws the hand back towards ``DRAW_BACK_Z`` (a
rise of 10-20 cm takes most of it; it holds still if it gets there), so the observations
show the released parts at rest past the hand (dev's packet ends on the goal)."""
DRAW_BACK_Z = 0.26
BOUNDARY_RESOLUTION = 10
"""Key-stage boundaries are rounded to multiples of this many observations (0.5 s)."""
GOAL_EVENTS = ("inserted", "turned", "placed", "opened", "closed", "pressed", "aligned")
COARSE_EVENTS = ("opened", "closed")
"""Goal events whose magnitude a coarse annotation still states (to a tenth)."""
_TEXT = {
    "proprio": "TCP x, y, z (m), yaw (rad), finger opening (m), left/right finger contact",
    "parts": "per part row: present, x, y, z, qw, qx, qy, qz, joint, age (s)",
    "force": "normal contact force on left finger, right finger, palm; net force x, y, z (N)",
    "goal": "[stated, g1, g2, g3]: the task's stated goal parameters (dev split only)",
}


def goal_value(event: str, final: float | None, values: str) -> float | None:
    """The ``value`` an annotation carries: the magnitude the demonstration reached on its
    goal event (``values == "exact"``); with ``"coarse"`` only an opening's fraction, to a
    tenth (an annotator's "about 70 % open": the joint's range is not in the observations),
    and nothing else (a depth, a turn, ... is read off the demonstration's observations)."""
    if event not in GOAL_EVENTS or final is None:
        return None
    if values == "exact":
        return float(final)
    return round(float(final), 1) + 0.0 if event in COARSE_EVENTS else None


def _spec(env: BenchEnv, key: str) -> ArraySpec:
    box = env.observation_space[key]
    names = {"proprio": PROPRIO_NAMES, "force": FORCE_NAMES, "parts": PART_FIELDS,
             "goal": GOAL_NAMES}[key]
    return ArraySpec(
        shape=tuple(int(x) for x in box.shape),  # type: ignore[union-attr]
        dtype=str(box.dtype),
        low=float(np.min(box.low)),  # type: ignore[attr-defined]
        high=float(np.max(box.high)),  # type: ignore[attr-defined]
        names=list(names),
        rows=list(env.task.part_names) if key == "parts" else [],
        description=_TEXT[key],
    )


def _segments(stages: list[int], names: list[str]) -> list[tuple[str, int, int]]:
    """Exact key-stage ranges from per-observation stage indices (running max; -1 = done)."""
    out: list[tuple[str, int, int]] = []
    best = -1
    for k, s in enumerate(stages):
        if s < 0:
            break
        best = max(best, s)
        if out and out[-1][0] == names[best]:
            out[-1] = (out[-1][0], out[-1][1], k + 1)
        else:
            out.append((names[best], k, k + 1))
    return out


def coarse_stages(stages: list[int], names: list[str], resolution: int) -> list[KeyStage]:
    """Key stages with inner boundaries rounded to multiples of ``resolution`` (kept in
    order and non-empty): what an annotator marks, not the true per-step stage."""
    exact = _segments(stages, names)
    if not exact:
        return []
    end = exact[-1][2]
    bounds = [0]
    for _, start, _ in exact[1:]:
        b = int(round(start / resolution)) * resolution
        bounds.append(min(max(b, bounds[-1] + 1), end - 1))
    out = []
    for i, (name, _, _) in enumerate(exact):
        hi = bounds[i + 1] if i + 1 < len(bounds) else end
        if hi > bounds[i]:
            out.append(KeyStage(name=name, start=bounds[i], end=hi))
    return out


def _draw_back(env: BenchEnv, grip: float) -> Iterator[np.ndarray]:
    """After the goal: straight up to ``DRAW_BACK_Z`` (the grip command kept: a tool stays
    in the hand), then still; the camera sees the result past the hand."""
    ee = env.sim.ee()
    width = (grip + 1.0) / 2.0 * WIDTH_MAX
    yield from move(env, np.array([ee[0], ee[1], DRAW_BACK_Z]), float(ee[3]), width, tol=0.004,
                    max_steps=POST_STEPS)
    while True:
        yield action(np.zeros(3), 0.0, width)


def write_demo_packet(
    folder: str | Path,
    params: InstanceParams,
    *,
    seed: int,
    config: BenchConfig | None = None,
    frames: bool = False,
    frame_every: int = 5,
    image_size: tuple[int, int] | None = None,
) -> DemoManifest:
    """Run the scripted expert on ``params`` and write the packet into ``folder``.

    Args:
      folder: created if missing; must not already hold a ``manifest.json``.
      params: the source instance.
      seed: passed to ``env.reset(seed=...)`` (jitter and observation noise); not written.
      config: the split's bench config (default: the dev split's).
      frames: also write the ``overview`` camera's RGB frames (and depth in
        ``frame_depth``) every ``frame_every`` observations and the last one; the packet
        carries that camera's frames only, not the ``front`` or ``top`` camera's.
      image_size: ``(height, width)`` of the frames (default: the config's).

    Returns:
      The manifest as written.
    """
    out = Path(folder)
    if (out / "manifest.json").exists():
        raise DemoPacketError(f"{out} already holds a demonstration packet; use an empty folder")
    out.mkdir(parents=True, exist_ok=True)
    env = BenchEnv(params, config=config, render_rgbd=None,
                   render_mode="rgb_array" if frames else None,
                   image_size=image_size)
    keys = [k for k in OBS_KEYS if k in env.observation_space.spaces]
    try:
        obs, info = env.reset_typed(seed=seed)
        expert = ScriptedExpert(env)
        names = list(env.task.stages())
        observations = {k: [obs[k]] for k in keys}
        actions = []
        stage_idx = [names.index(info.stage) if info.stage in names else -1]
        events: list[tuple[int, dict[str, str]]] = []
        shots: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        if frames:
            shots[0] = env._render(depth=True)[:2]
        done, tail, success, final = False, None, False, None
        while not done:
            if tail is None:
                action = expert()
            else:
                action = next(tail)
            obs, _, term, trunc, info = env.step_typed(action)
            k = len(actions) + 1
            actions.append(np.asarray(action, dtype=np.float32))
            if tail is None:
                stage_idx.append(names.index(info.stage) if info.stage in names else -1)
            else:  # drawing back belongs to the last key stage
                stage_idx.append(next((s for s in reversed(stage_idx) if s >= 0), -1))
            for key in keys:
                observations[key].append(obs[key])
            events += [(k, e) for e in info.events]
            if tail is None and (term or trunc):
                success, final = bool(info.success), info.value
                if not success or env.config.demo_values == "exact":
                    done = True  # dev: today's packet, ending on the goal
                else:  # the demonstrator draws the hand back (then holds still); that
                    # belongs to the last key stage, the last observation shows it done
                    stage_idx[-1] = next((s for s in reversed(stage_idx) if s >= 0), -1)
                    tail, left = _draw_back(env, float(action[4])), POST_STEPS
            elif tail is not None:
                left -= 1
                done = left <= 0
                if done:
                    stage_idx[-1] = -1
            if frames and (k % frame_every == 0 or done):
                shots[k] = env._render(depth=True)[:2]
        space = {k: _spec(env, k) for k in keys}
        size = env.image_size
    finally:
        env.close()
    arrays: dict[str, np.ndarray] = {"actions": np.stack(actions).astype(np.float32)}
    for key in keys:
        arrays[f"obs_{key}"] = np.stack(observations[key]).astype(np.float32)
    frame_spec = None
    if frames:
        (out / "frames").mkdir(exist_ok=True)
        steps = sorted(shots)
        for k in steps:
            (out / "frames" / f"{k:06d}.png").write_bytes(encode_png(shots[k][0]))
        depth = np.stack([shots[k][1] for k in steps])
        arrays["frame_depth"] = np.clip(depth, 0.0, 10.0).astype(np.float32)  # as observed
        frame_spec = FrameSpec(height=size[0], width=size[1], steps=steps, depth=True)
    np.savez_compressed(out / "trajectory.npz", **arrays)  # type: ignore[arg-type]
    manifest = DemoManifest(
        family=params.family,
        control_hz=CONTROL_HZ,
        num_steps=len(actions),
        success=success,
        action_spec=ArraySpec(shape=(5,), dtype="float32", low=-1.0, high=1.0,
                              names=list(ACTION_NAMES),
                              description="dx, dy, dz, dyaw (scaled by action_scale), grip"),
        action_scale={"dx": DPOS_MAX, "dy": DPOS_MAX, "dz": DPOS_MAX, "dyaw": DYAW_MAX,
                      "grip": WIDTH_MAX},
        observation_spec=space,
        stage_names=names,
        key_stages=coarse_stages(stage_idx, names, BOUNDARY_RESOLUTION),
        boundary_resolution=BOUNDARY_RESOLUTION,
        events=[Annotation(step=k, event=e["event"], part=e["part"],
                           value=goal_value(e["event"], final, env.config.demo_values))
                for k, e in events],
        frames=frame_spec,
    )
    (out / "manifest.json").write_text(manifest.model_dump_json(indent=2) + "\n")
    return manifest
