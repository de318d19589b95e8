"""MuJoCo environments, the sim host that serves an episode over Zenoh, and the agent client.

Three audiences, three folders:

- ``simhost.client``: what a team's container installs and imports (``RemoteEnv``, the
  gymnasium-style ``GymEnv``, ``OutputFiles``, the Track 1 skills ``simhost.client.skills``).
  It needs only pydantic, eclipse-zenoh and numpy (``tests/simhost/test_client_light.py``).
- ``simhost.host``: what organizers run: the sim host, its MCAP recorder and the typed
  reader of its records.
- ``simhost.worlds``: the tracks' simulators (``sanity``, ``track1``, ``track2``) and their
  assets.

Beside them at the top: the wire codec (``_wire``: ``encode``, ``decode_request``,
``decode_reply``, ``WireError``) and the transport (``_transport``) that host and client
share, and the error root (``SimHostError``). ``__all__`` is what other packages may import
(``tests/test_public_surface.py``). Nothing heavy is imported
here; names below load their module on first use. The paths that moved to these folders
(``simhost.agent``, ``simhost.skills``, ``simhost.track1`` …) still import, with a
``DeprecationWarning`` naming the new path (``CHANGELOG.md``).

Gymnasium (≥ 1.0) convention: ``import simhost`` registers every eagc environment, so that
``gymnasium.make("simhost:eagc/House-v0")`` works in a fresh process, as does
``import simhost`` followed by ``gymnasium.make("eagc/House-v0")``. Each world keeps its ids
in its own ``simhost/worlds/<track>/_register.py`` (a ``register_envs()`` with string entry
points: MuJoCo loads only when an env is made); every such module is found here, so a new
track needs nothing else. When gymnasium is not imported yet, the registration runs the
moment it is (a one-shot import hook), so that a process that never uses gymnasium (a team's
agent, which may not even have it) pays nothing for it: no gymnasium, no world imported.
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
    "RemoteEnv": "simhost.client",
    "TimeStep": "simhost.client",
    "HostError": "simhost.client",
    "HostLost": "simhost.client",
    "SimHostError": "simhost._errors",
    "WireError": "simhost._wire",
    "encode": "simhost._wire",
    "decode_reply": "simhost._wire",
    "decode_request": "simhost._wire",
    "OutputFiles": "simhost.client._outputs",
    "OutputFileError": "simhost.client._outputs",
    "Pose": "simhost.host._episode",
    "SimHost": "simhost.host._host",
    "HostConfig": "simhost.host._host",
    "HostOutcome": "simhost.host._host",
    "HostProgress": "simhost.host._host",
    "EpisodeRecorder": "simhost.host._host",
    "TrackEpisode": "simhost.host._episode",
    "StageSpec": "simhost.host._episode",
    "Observation": "simhost.host._episode",
    "StepOutcome": "simhost.host._episode",
    "ActionError": "simhost.host._actions",
    "check_action": "simhost.host._actions",
    "McapRecorder": "simhost.host._mcap",
    "encode_png": "simhost.host._png",
    "write_png": "simhost.host._png",
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
    "WireError",
    "check_action",
    "decode_reply",
    "decode_request",
    "encode",
    "encode_png",
    "env_ids",
    "write_png",
]

if TYPE_CHECKING:
    from simhost._errors import SimHostError
    from simhost._wire import WireError, decode_reply, decode_request, encode
    from simhost.client import HostError, HostLost, RemoteEnv, TimeStep
    from simhost.client._outputs import OutputFileError, OutputFiles
    from simhost.host._actions import ActionError, check_action
    from simhost.host._episode import Observation, Pose, StageSpec, StepOutcome, TrackEpisode
    from simhost.host._host import EpisodeRecorder, HostConfig, HostOutcome, HostProgress, SimHost
    from simhost.host._mcap import McapRecorder
    from simhost.host._png import encode_png, write_png


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
    for register in sorted((Path(__file__).parent / "worlds").glob("*/_register.py")):
        track = register.parent.name
        try:
            importlib.import_module(f"simhost.worlds.{track}._register").register_envs()
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


#: Public paths that moved, and where they went (one minor version of warnings: CHANGELOG.md).
MOVED = {
    "simhost.agent": "simhost.client",
    "simhost.skills": "simhost.client.skills",
    "simhost.track1": "simhost.worlds.track1",
    "simhost.track2": "simhost.worlds.track2",
    "simhost.sanity": "simhost.worlds.sanity",
    "simhost.assets": "simhost.worlds.assets",
    "simhost._remote": "simhost.client._remote",
    "simhost._gym_client": "simhost.client._gym_client",
    "simhost._outputs": "simhost.client._outputs",
    "simhost._plain_spaces": "simhost.client._plain_spaces",
    "simhost._host": "simhost.host._host",
    "simhost._mcap": "simhost.host._mcap",
    "simhost._records": "simhost.host._records",
    "simhost._episode": "simhost.host._episode",
    "simhost._actions": "simhost.host._actions",
    "simhost._png": "simhost.host._png",
}


def _moved_to(fullname: str) -> str | None:
    """The new dotted name of a moved module or of a module inside a moved package."""
    for old, new in MOVED.items():
        if fullname == old or fullname.startswith(old + "."):
            return new + fullname[len(old):]
    return None


class _Alias(importlib.abc.Loader):
    """Loads an old path as the very module of its new path (one object, not a copy)."""

    def __init__(self, old: str, new: str) -> None:
        self.old, self.new = old, new
        self.spec: importlib.machinery.ModuleSpec | None = None

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        warnings.warn(f"{self.old} moved to {self.new}; import it from there "
                      f"(the old path goes in eagc 0.3, CHANGELOG.md)",
                      DeprecationWarning, stacklevel=2)
        module = importlib.import_module(self.new)
        self.spec = module.__spec__
        return module

    def exec_module(self, module: ModuleType) -> None:
        # The import system stamps the old spec on the module: give it back its own.
        module.__spec__ = self.spec
        sys.modules[self.old] = module


class _MovedPaths(importlib.abc.MetaPathFinder):
    """Finds the old paths of ``MOVED``, so that code written against them keeps working."""

    def find_spec(self, fullname: str, path: Sequence[str] | None,
                  target: ModuleType | None = None) -> importlib.machinery.ModuleSpec | None:
        new = _moved_to(fullname)
        if new is None:
            return None
        return importlib.machinery.ModuleSpec(fullname, _Alias(fullname, new))


if not any(isinstance(f, _MovedPaths) for f in sys.meta_path):
    sys.meta_path.insert(0, _MovedPaths())
