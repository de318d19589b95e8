"""Finding track plugins through the ``eagc.tracks`` entry points, lazily, checked on load."""

from __future__ import annotations

import difflib
import math
from functools import cache
from importlib.metadata import EntryPoint, entry_points

from pydantic import BaseModel

from plugins._base import TrackPlugin
from plugins._errors import PluginError
from simhost.host._episode import EpisodeOutcome

GROUP = "eagc.tracks"


def _entry_points() -> dict[str, EntryPoint]:
    return {ep.name: ep for ep in entry_points(group=GROUP)}


def available_tracks() -> list[str]:
    """Names of the installed tracks (nothing is imported)."""
    return sorted(_entry_points())


def validate_plugin(plugin: TrackPlugin, *, name: str) -> None:
    """Checks a plugin instance; raises PluginError naming the plugin and what is wrong."""
    where = f"track plugin {name!r} ({type(plugin).__module__}.{type(plugin).__qualname__})"
    problems: list[str] = []
    for attr in ("name", "title", "weights", "files", "splits", "scenario_model",
                 "outcome_model"):
        if not hasattr(plugin, attr):
            problems.append(f"class attribute {attr!r} is missing")
    if problems:
        raise PluginError(f"{where}: " + "; ".join(problems))
    for attr, base, called in (("scenario_model", BaseModel, "pydantic.BaseModel"),
                               ("outcome_model", EpisodeOutcome, "plugins.EpisodeOutcome")):
        model = getattr(plugin, attr)
        if not (isinstance(model, type) and issubclass(model, base)):
            problems.append(f"{attr} is {model!r}, not a subclass of {called}")
    if plugin.name != name:
        problems.append(f"name is {plugin.name!r} but it is registered as {name!r}")
    total = sum(plugin.weights.values())
    if not math.isclose(total, 1.0, abs_tol=1e-9):
        problems.append(f"weights sum to {total}, not 1")
    if not plugin.splits:
        problems.append("no splits")
    try:
        stages = plugin.stages()
    except Exception as e:  # noqa: BLE001 - report, don't crash the caller
        problems.append(f"stages() raised {type(e).__name__}: {e}")
        stages = []
    names = [s.name for s in stages]
    if not stages:
        problems.append("stages() is empty")
    if len(set(names)) != len(names):
        problems.append(f"stage names repeat: {names}")
    for s in stages:
        if not s.budget_s > 0:
            problems.append(f"stage {s.name!r} has budget {s.budget_s}; it must be > 0")
    if problems:
        raise PluginError(f"{where}:\n  - " + "\n  - ".join(problems))


@cache
def load_track(name: str) -> TrackPlugin:
    """The plugin registered as ``name``, imported on first use and validated."""
    eps = _entry_points()
    if name not in eps:
        hint = difflib.get_close_matches(name, eps, n=1)
        did = f" Did you mean {hint[0]!r}?" if hint else ""
        raise PluginError(
            f"no track named {name!r}.{did} Installed: {sorted(eps) or 'none'} "
            f"(tracks register under the entry-point group {GROUP!r}; reinstall with "
            "`pip install -e .` after adding one)"
        )
    try:
        cls = eps[name].load()
    except Exception as e:  # noqa: BLE001
        raise PluginError(f"track {name!r}: importing {eps[name].value} failed: {e}") from e
    if not (isinstance(cls, type) and issubclass(cls, TrackPlugin)):
        raise PluginError(
            f"track {name!r}: {eps[name].value} is {cls!r}, not a subclass of "
            "plugins.TrackPlugin"
        )
    try:
        plugin = cls()
    except TypeError as e:
        raise PluginError(f"track {name!r}: cannot instantiate {cls.__qualname__}: {e}") from e
    validate_plugin(plugin, name=name)
    return plugin
