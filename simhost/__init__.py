"""MuJoCo environments, the sim host that serves an episode over Zenoh, and the agent client.

Nothing heavy is imported here: team containers ``import simhost.agent`` with only pydantic,
eclipse-zenoh and numpy installed. Names below load their module on first use.

Gymnasium (≥ 1.0) convention: ``import simhost`` registers every eagc environment, so that
``gymnasium.make("simhost:eagc/House-v0")`` works in a fresh process, as does
``import simhost`` followed by ``gymnasium.make("eagc/House-v0")``. Each track keeps its ids
in its own ``simhost/<track>/_register.py`` (a ``register_envs()`` with string entry points:
MuJoCo loads only when an env is made); every such module is found here, so a new track
needs nothing else. When gymnasium is not imported yet, the registration runs the moment it
is (a one-shot import hook), so that a process that never uses gymnasium (a team's agent,
which may not even have it) pays nothing for it: no gymnasium, no track package imported.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

_EXPORTS = {
    "RemoteEnv": "simhost.agent",
    "TimeStep": "simhost.agent",
    "HostError": "simhost.agent",
    "HostLost": "simhost.agent",
    "SimHostError": "simhost._errors",
    "OutputFiles": "simhost._outputs",
    "OutputFileError": "simhost._outputs",
    "Pose": "simhost._episode",
    "SimHost": "simhost._host",
    "HostConfig": "simhost._host",
    "HostOutcome": "simhost._host",
    "HostProgress": "simhost._host",
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
    "HostLost",
    "HostOutcome",
    "HostProgress",
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
    "env_ids",
    "write_png",
]

if TYPE_CHECKING:
    from simhost._actions import ActionError, check_action
    from simhost._episode import Observation, Pose, StageSpec, StepOutcome, TrackEpisode
    from simhost._errors import SimHostError
    from simhost._host import EpisodeRecorder, HostConfig, HostOutcome, HostProgress, SimHost
    from simhost._mcap import McapRecorder
    from simhost._outputs import OutputFileError, OutputFiles
    from simhost._png import encode_png, write_png
    from simhost.agent import HostError, HostLost, RemoteEnv, TimeStep


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'simhost' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


def env_ids() -> list[str]:
    """The gymnasium ids of every eagc environment (imports gymnasium; empty without it)."""
    try:
        from gymnasium.envs.registration import registry
    except ImportError:
        return []
    return sorted(
        env_id for env_id, spec in registry.items()
        if isinstance(spec.entry_point, str) and spec.entry_point.startswith("simhost.")
    )


def _register_envs() -> None:
    """Calls every track's ``register_envs()`` (gymnasium is imported by now)."""
    for register in sorted(Path(__file__).parent.glob("*/_register.py")):
        track = register.parent.name
        try:
            importlib.import_module(f"simhost.{track}._register").register_envs()
        except Exception as e:  # noqa: BLE001 - never break the import of gymnasium
            warnings.warn(f"simhost: the {track} environments are not registered: "
                          f"{type(e).__name__}: {e}", stacklevel=2)


class _RegisterWithGymnasium(importlib.abc.MetaPathFinder):
    """One shot: when gymnasium is imported, registers the envs right after it loads."""

    def find_spec(self, fullname: str, path: Sequence[str] | None,
                  target: ModuleType | None = None) -> importlib.machinery.ModuleSpec | None:
        if fullname != "gymnasium":
            return None
        if self in sys.meta_path:
            sys.meta_path.remove(self)
        spec = importlib.util.find_spec(fullname)
        loader = None if spec is None else spec.loader
        if loader is None or not hasattr(loader, "exec_module"):
            return spec
        load = loader.exec_module

        def load_and_register(module: ModuleType) -> None:
            load(module)
            _register_envs()

        loader.exec_module = load_and_register  # type: ignore[method-assign]
        return spec


if sys.modules.get("gymnasium") is not None:
    _register_envs()
elif not any(isinstance(f, _RegisterWithGymnasium) for f in sys.meta_path):
    sys.meta_path.insert(0, _RegisterWithGymnasium())
