"""``write_demo_packet``: run the scripted expert on a source instance, write the packet.

The format is described in ``_packet.py`` (``eagc-demo/v1``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._png import encode_png
from ._bench import (
    ACTION_NAMES,
    CONTROL_HZ,
    DPOS_MAX,
    DYAW_MAX,
    FORCE_NAMES,
    PHYSICS_DT,
    PROPRIO_NAMES,
    SUBSTEPS,
    WIDTH_MAX,
)
from ._env import BenchEnv
from ._errors import DemoPacketError
from ._expert import ScriptedExpert
from ._family import GOAL_NAMES, PART_FIELDS
from ._packet import OBS_KEYS, Annotation, ArraySpec, DemoManifest, FrameSpec, KeyStage
from ._params import InstanceParams


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
    )


def _segments(stages: list[int], names: list[str]) -> list[KeyStage]:
    """Key-stage ranges from per-observation stage indices (running maximum; -1 = done)."""
    out: list[KeyStage] = []
    best = -1
    for k, s in enumerate(stages):
        if s < 0:
            break
        best = max(best, s)
        if out and out[-1].name == names[best]:
            out[-1] = KeyStage(name=out[-1].name, start=out[-1].start, end=k + 1)
        else:
            out.append(KeyStage(name=names[best], start=k, end=k + 1))
    return out


def write_demo_packet(
    folder: str | Path,
    params: InstanceParams,
    *,
    seed: int,
    frames: bool = False,
    frame_every: int = 5,
    image_size: tuple[int, int] = (120, 160),
) -> DemoManifest:
    """Run the scripted expert on ``params`` and write the packet into ``folder``.

    Args:
      folder: created if missing; must not already hold a ``manifest.json``.
      params: the source instance.
      seed: passed to ``env.reset(seed=...)``; not written to the packet.
      frames: also write PNG frames every ``frame_every`` observations (and the last one).
      image_size: ``(height, width)`` of the frames.

    Returns:
      The manifest as written.
    """
    out = Path(folder)
    if (out / "manifest.json").exists():
        raise DemoPacketError(f"{out} already holds a demonstration packet; use an empty folder")
    out.mkdir(parents=True, exist_ok=True)
    env = BenchEnv(params, render_mode="rgb_array" if frames else None, image_size=image_size)
    try:
        obs, info = env.reset(seed=seed)
        expert = ScriptedExpert(env)
        names = list(env.task.stages())
        observations = {k: [obs[k]] for k in OBS_KEYS}
        actions, rewards, progress = [], [], [info["progress"]]
        stage_idx = [names.index(info["stage"]) if info["stage"] in names else -1]
        events: list[Annotation] = []
        shots: dict[int, np.ndarray] = {0: env.render()} if frames else {}  # type: ignore[dict-item]
        done = False
        while not done:
            action = expert()
            obs, reward, term, trunc, info = env.step(action)
            k = len(actions) + 1
            actions.append(np.asarray(action, dtype=np.float32))
            rewards.append(reward)
            progress.append(info["progress"])
            stage_idx.append(names.index(info["stage"]) if info["stage"] in names else -1)
            for k_obs in OBS_KEYS:
                observations[k_obs].append(obs[k_obs])
            events += [Annotation(step=k, **e) for e in info["events"]]
            done = term or trunc
            if frames and (k % frame_every == 0 or done):
                shots[k] = env.render()  # type: ignore[assignment]
        success = bool(info["success"])
    finally:
        env.close()
    arrays: dict[str, np.ndarray] = {
        "actions": np.stack(actions).astype(np.float32),
        "reward": np.asarray(rewards, dtype=np.float32),
        "progress": np.asarray(progress, dtype=np.float32),
        "stage": np.asarray(stage_idx, dtype=np.int16),
    }
    for k_obs in OBS_KEYS:
        arrays[f"obs_{k_obs}"] = np.stack(observations[k_obs]).astype(np.float32)
    np.savez_compressed(out / "trajectory.npz", **arrays)  # type: ignore[arg-type]
    frame_spec = None
    if frames:
        (out / "frames").mkdir(exist_ok=True)
        for k, img in shots.items():
            (out / "frames" / f"{k:06d}.png").write_bytes(encode_png(img))
        frame_spec = FrameSpec(height=image_size[0], width=image_size[1], steps=sorted(shots))
    manifest = DemoManifest(
        family=params.family,
        source=params.public(),
        control_hz=CONTROL_HZ,
        physics_dt=PHYSICS_DT,
        substeps=SUBSTEPS,
        num_steps=len(actions),
        success=success,
        action_spec=ArraySpec(shape=(5,), dtype="float32", low=-1.0, high=1.0,
                              names=list(ACTION_NAMES)),
        action_scale={"dx": DPOS_MAX, "dy": DPOS_MAX, "dz": DPOS_MAX, "dyaw": DYAW_MAX,
                      "grip": WIDTH_MAX},
        observation_spec={k: _spec(env, k) for k in OBS_KEYS},
        stage_names=names,
        key_stages=_segments(stage_idx, names),
        events=events,
        frames=frame_spec,
    )
    (out / "manifest.json").write_text(manifest.model_dump_json(indent=2) + "\n")
    return manifest


