"""MuJoCo environments, the sim host that serves an episode over Zenoh, and the agent client.

Nothing heavy is imported here: team containers ``import simhost.agent`` with only pydantic,
eclipse-zenoh and numpy installed. Names below load their module on first use.

Gymnasium (≥ 1.0) convention: where gymnasium is installed, ``import simhost`` registers
every eagc environment, so that ``gymnasium.make("simhost:eagc/House-v0")`` works in a fresh
process. Each track keeps its ids in its own ``simhost/<track>/_register.py`` (a
``register_envs()`` with string entry points: MuJoCo loads only when an env is made); every
such module is found here, so a new track needs nothing else. Without gymnasium (a team's
container) nothing is registered and nothing more is imported.
"""

from __future__ import annotations

import importlib
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

_EXPORTS = {
    "RemoteEnv": "simhost.agent",
    "TimeStep": "simhost.agent",
    "HostError": "simhost.agent",
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
    "StageSpec",
    "StepOutcome",
    "TimeStep",
    "TrackEpisode",
    "check_action",
    "encode_png",
    "env_ids",
    "write_png",
]

if TYPE_CHECKING:
    from simhost._actions import ActionError, check_action
    from simhost._episode import Observation, Pose, StageSpec, StepOutcome, TrackEpisode
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


def env_ids() -> list[str]:
    """The gymnasium ids of every eagc environment registered (empty without gymnasium)."""
    try:
        from gymnasium.envs.registration import registry
    except ImportError:
        return []
    return sorted(
        env_id for env_id, spec in registry.items()
        if isinstance(spec.entry_point, str) and spec.entry_point.startswith("simhost.")
    )


def _register_envs() -> None:
    try:
        import gymnasium  # noqa: F401 - only to know whether it is there
    except ImportError:
        return
    for register in sorted(Path(__file__).parent.glob("*/_register.py")):
        track = register.parent.name
        try:
            importlib.import_module(f"simhost.{track}._register").register_envs()
        except ImportError as e:  # e.g. a track's own dependency missing in this image
            warnings.warn(f"simhost: the {track} environments are not registered: {e}",
                          stacklevel=2)


_register_envs()
