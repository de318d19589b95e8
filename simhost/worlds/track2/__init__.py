"""Track 2 bench: one-demonstration manipulation tasks in MuJoCo.

Five task families (the paper's Table VI) on one table with a two-finger gripper driven by
end-effector deltas at 20 Hz: ``insertion``, ``rotation``, ``assembly``, ``opening``,
``tool_use``. Three splits (``SPLITS``): the public ``dev`` split (exact state, a stated goal,
narrow ranges) and the official ``standard`` and ``challenge`` splits (a robot's noisy,
delayed, occluded view, RGB-D, a goal defined by the demonstration, wide ranges). What a
user may touch:

- splits: :class:`SplitConfig` = :class:`BenchConfig` (:class:`ObservationConfig`,
  :class:`Tolerances`, grip slip, per-attempt jitter) + :class:`VariationConfig`;
  ``SPLITS``, :func:`split_config`;
- instances: :class:`InstanceParams`, :func:`default_source`, :func:`sample_instance`,
  :func:`instance_distance`, ``FAMILIES``, ``PARAM_TABLES``, :func:`family_step_cap`;
- the environment: :class:`BenchEnv` (a ``gymnasium.Env``; :class:`BenchInfo`, its
  ``info`` typed), :func:`register_envs`
  (``eagc/Bench-<Family>-v0``, ``split=`` as a keyword), ``PART_FIELDS``, ``CAMERAS`` (the
  three cameras of the RGB-D observation), ``CAMERA_FOVY``, ``TOP_POS`` and ``TOP_FOVY``;
- ground truth for scoring: :class:`TaskTruth`, :func:`task_truth`;
- the scripted expert: :class:`ScriptedExpert` (privileged, or through the observations),
  :func:`expert_policy`;
- demonstration packets (``eagc-demo/v2``): :func:`write_demo_packet`,
  :func:`read_demo_packet`, :class:`DemoPacket` (the manifest model is
  ``schemas.DemoManifest``);
- a picture: :func:`render_attempt_vs_demo`, and what a track's own pictures draw with:
  :class:`Canvas`, :func:`decode_png`, :func:`resize_rgb`, the colours ``DEMO_RGB``,
  ``ATTEMPT_RGB``, ``INK``, ``PAPER``; :func:`quat_z` (a yaw as a quaternion);
- errors: :class:`Track2Error` and its subclasses.

Configs, instance parameters, the truth, the packet reader and the picture import without
MuJoCo; the environment, expert and packet writer load it on first use. ``MUJOCO_GL``
defaults to ``egl`` (headless) unless already set.
"""

from __future__ import annotations

import importlib
import os
from typing import TYPE_CHECKING, Any

from ._bench import CAMERA_FOVY, CAMERAS, PART_FIELDS, TOP_FOVY, TOP_POS
from ._config import (
    OFFICIAL_IMAGE_SIZE,
    SPLITS,
    BenchConfig,
    ObservationConfig,
    SplitConfig,
    Tolerances,
    VariationConfig,
    split_config,
)
from ._errors import (
    DemoPacketError,
    InstanceParamsError,
    SplitConfigError,
    StateError,
    Track2Error,
)
from ._families import family_step_cap, task_truth
from ._info import BenchInfo
from ._params import (
    FAMILIES,
    PARAM_TABLES,
    InstanceParams,
    ParamSpec,
    default_source,
    instance_distance,
    sample_instance,
)
from ._register import ENV_IDS, env_id, register_envs
from ._truth import TaskTruth, TruthConstraint, TruthCriterion, TruthVariable

os.environ.setdefault("MUJOCO_GL", "egl")

if TYPE_CHECKING:
    from ._demo import write_demo_packet
    from ._env import BenchEnv
    from ._expert import ScriptedExpert, expert_policy
    from ._observe import quat_z
    from ._packet import DemoPacket, read_demo_packet
    from ._picture import ATTEMPT_RGB, DEMO_RGB, INK, PAPER, render_attempt_vs_demo, resize_rgb
    from ._raster import Canvas, decode_png

_LAZY = {
    "BenchEnv": "._env",
    "ScriptedExpert": "._expert",
    "expert_policy": "._expert",
    "DemoPacket": "._packet",
    "read_demo_packet": "._packet",
    "write_demo_packet": "._demo",
    "render_attempt_vs_demo": "._picture",
    "resize_rgb": "._picture",
    "ATTEMPT_RGB": "._picture",
    "DEMO_RGB": "._picture",
    "INK": "._picture",
    "PAPER": "._picture",
    "Canvas": "._raster",
    "decode_png": "._raster",
    "quat_z": "._observe",
}

__all__ = [
    "ATTEMPT_RGB",
    "CAMERAS",
    "CAMERA_FOVY",
    "DEMO_RGB",
    "ENV_IDS",
    "INK",
    "FAMILIES",
    "PARAM_TABLES",
    "PAPER",
    "PART_FIELDS",
    "OFFICIAL_IMAGE_SIZE",
    "SPLITS",
    "TOP_FOVY",
    "TOP_POS",
    "BenchConfig",
    "BenchEnv",
    "BenchInfo",
    "Canvas",
    "DemoPacket",
    "DemoPacketError",
    "InstanceParams",
    "InstanceParamsError",
    "ObservationConfig",
    "ParamSpec",
    "ScriptedExpert",
    "SplitConfig",
    "SplitConfigError",
    "StateError",
    "TaskTruth",
    "Tolerances",
    "Track2Error",
    "TruthConstraint",
    "TruthCriterion",
    "TruthVariable",
    "VariationConfig",
    "decode_png",
    "default_source",
    "env_id",
    "expert_policy",
    "family_step_cap",
    "instance_distance",
    "quat_z",
    "read_demo_packet",
    "register_envs",
    "render_attempt_vs_demo",
    "resize_rgb",
    "sample_instance",
    "split_config",
    "task_truth",
    "write_demo_packet",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
