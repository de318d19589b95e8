"""Track 2 bench: one-demonstration manipulation tasks in MuJoCo.

Five task families (the paper's Table VI) on one table with a two-finger gripper driven by
end-effector deltas at 20 Hz: ``insertion``, ``rotation``, ``assembly``, ``opening``,
``tool_use``. What a user may touch:

- instances: :class:`InstanceParams`, :func:`default_source`, :func:`sample_instance`,
  :func:`instance_distance`, ``FAMILIES``, ``PARAM_TABLES``;
- the environment: :class:`BenchEnv` (a ``gymnasium.Env``), :func:`register_envs`
  (``eagc/Bench-<Family>-v0``);
- ground truth for scoring: :func:`task_truth`;
- the scripted expert: :class:`ScriptedExpert`, :func:`expert_policy`;
- demonstration packets: :func:`write_demo_packet`, :func:`read_demo_packet`,
  :class:`DemoPacket`, :class:`DemoManifest`;
- a picture: :func:`render_attempt_vs_demo`;
- errors: :class:`Track2Error` and its subclasses.

Instance parameters, the truth, the packet reader and the picture import without MuJoCo; the
environment, expert and packet writer load it on first use. ``MUJOCO_GL`` defaults to
``egl`` (headless) unless already set.
"""

from __future__ import annotations

import importlib
import os
from typing import TYPE_CHECKING, Any

from ._errors import DemoPacketError, InstanceParamsError, StateError, Track2Error
from ._params import (
    FAMILIES,
    PARAM_TABLES,
    InstanceParams,
    ParamSpec,
    default_source,
    instance_distance,
    sample_instance,
)

os.environ.setdefault("MUJOCO_GL", "egl")

if TYPE_CHECKING:
    from ._demo import write_demo_packet
    from ._env import BenchEnv, register_envs
    from ._expert import ScriptedExpert, expert_policy
    from ._packet import DemoManifest, DemoPacket, read_demo_packet
    from ._picture import render_attempt_vs_demo
    from ._truth import task_truth

_LAZY = {
    "BenchEnv": "._env",
    "register_envs": "._env",
    "ScriptedExpert": "._expert",
    "expert_policy": "._expert",
    "DemoManifest": "._packet",
    "DemoPacket": "._packet",
    "read_demo_packet": "._packet",
    "write_demo_packet": "._demo",
    "render_attempt_vs_demo": "._picture",
    "task_truth": "._truth",
}

__all__ = [
    "FAMILIES",
    "PARAM_TABLES",
    "BenchEnv",
    "DemoManifest",
    "DemoPacket",
    "DemoPacketError",
    "InstanceParams",
    "InstanceParamsError",
    "ParamSpec",
    "ScriptedExpert",
    "StateError",
    "Track2Error",
    "default_source",
    "expert_policy",
    "instance_distance",
    "read_demo_packet",
    "register_envs",
    "render_attempt_vs_demo",
    "sample_instance",
    "task_truth",
    "write_demo_packet",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
