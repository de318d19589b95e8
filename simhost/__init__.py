"""MuJoCo environments, the sim host that serves an episode over Zenoh, and the agent client.

Nothing heavy is imported here: team containers ``import simhost.agent`` with only pydantic,
eclipse-zenoh and numpy installed. Names below load their module on first use.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_EXPORTS = {
    "RemoteEnv": "simhost.agent",
    "TimeStep": "simhost.agent",
    "HostError": "simhost.agent",
    "SimHostError": "simhost._errors",
    "OutputFiles": "simhost._outputs",
    "OutputFileError": "simhost._outputs",
    "Pose": "simhost._episode",
    "SimHost": "simhost._host",
    "HostConfig": "simhost._host",
    "HostOutcome": "simhost._host",
    "EpisodeRecorder": "simhost._host",
    "TrackEpisode": "simhost._episode",
    "StageSpec": "simhost._episode",
    "Observation": "simhost._episode",
    "StepOutcome": "simhost._episode",
    "ActionError": "simhost._actions",
    "check_action": "simhost._actions",
    "McapRecorder": "simhost._mcap",
    "encode_png": "simhost._png",
    "write_png": "simhost._png",
}

__all__ = [
    "ActionError",
    "EpisodeRecorder",
    "HostConfig",
    "HostError",
    "HostOutcome",
    "McapRecorder",
    "Observation",
    "OutputFileError",
    "OutputFiles",
    "Pose",
    "RemoteEnv",
    "SimHost",
    "SimHostError",
    "StageSpec",
    "StepOutcome",
    "TimeStep",
    "TrackEpisode",
    "check_action",
    "encode_png",
    "write_png",
]

if TYPE_CHECKING:
    from simhost._actions import ActionError, check_action
    from simhost._episode import Observation, Pose, StageSpec, StepOutcome, TrackEpisode
    from simhost._errors import SimHostError
    from simhost._host import EpisodeRecorder, HostConfig, HostOutcome, SimHost
    from simhost._mcap import McapRecorder
    from simhost._outputs import OutputFileError, OutputFiles
    from simhost._png import encode_png, write_png
    from simhost.agent import HostError, RemoteEnv, TimeStep


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'simhost' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)
