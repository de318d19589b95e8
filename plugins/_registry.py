"""Finding track plugins through the ``eagc.tracks`` entry points, lazily, checked on load.

``registered_track(name, cls)`` adds a track for the length of a ``with`` block only (a
test's toy track, defined outside any installed package): within it the track loads like
an installed one, in this process; outside it, and in any other process, it does not
exist.
"""

from __future__ import annotations

import difflib
import inspect
import math
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from importlib.metadata import EntryPoint, entry_points
from typing import Any

from pydantic import BaseModel

from plugins._base import TrackPlugin
from plugins._errors import PluginError
from simhost.host import EpisodeOutcome

GROUP = "eagc.tracks"

#: Tracks registered for a ``with`` block (``registered_track``), by name.
_registered: dict[str, type[TrackPlugin]] = {}
#: Plugins loaded so far, by name (each is made and validated once).
_loaded: dict[str, TrackPlugin] = {}
_lock = threading.Lock()


def _entry_points() -> dict[str, EntryPoint]:
    return {ep.name: ep for ep in entry_points(group=GROUP)}


def available_tracks() -> list[str]:
    """Names of the installed tracks, and of those registered now (nothing is imported)."""
    return sorted({*_entry_points(), *_registered})


@contextmanager
def registered_track(name: str, cls: type[TrackPlugin]) -> Iterator[TrackPlugin]:
    """Makes ``cls`` the track ``name`` for the ``with`` block: it is listed, loads and is
    validated as an installed track would be; yields the plugin. Raises ``PluginError``
    when the name is taken or the plugin does not validate."""
    with _lock:
        if name in _registered or name in _entry_points():
            raise PluginError(f"a track named {name!r} is already registered")
        _registered[name] = cls
    try:
        yield load_track(name)
    finally:
        with _lock:
            _registered.pop(name, None)
            _loaded.pop(name, None)


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
    problems += _hook_problems(plugin)
    if problems:
        raise PluginError(f"{where}:\n  - " + "\n  - ".join(problems))


#: The methods of ``TrackPlugin`` a track may override, with defaults.
HOOKS = ("summarize", "stratum", "write_inputs", "verify_files", "picture", "preview", "audit",
         "episode_map", "step_pictures", "truth", "vocabulary")


def _arguments(fn: Callable[..., Any]) -> list[tuple[str, Any]]:
    return [(p.name, p.kind) for p in inspect.signature(fn).parameters.values()]


def _called(name: str, fn: Callable[..., Any]) -> str:
    """``name(a, b, *, c)``: the arguments ``fn`` takes, by name."""
    out: list[str] = []
    for p in inspect.signature(fn).parameters.values():
        if p.kind is p.KEYWORD_ONLY and "*" not in out:
            out.append("*")
        out.append(p.name)
    return f"{name}({', '.join(out)})"


def _hook_problems(plugin: TrackPlugin) -> list[str]:
    """Each hook the plugin overrides that does not take the arguments ``TrackPlugin``'s
    does (the viewer, the audit and the protocol page call them by those names)."""
    out = []
    for hook in HOOKS:
        mine, base = getattr(type(plugin), hook, None), getattr(TrackPlugin, hook)
        if mine is base:
            continue
        if not callable(mine):
            out.append(f"hook {hook!r} is {mine!r}, not a method")
        elif _arguments(mine) != _arguments(base):
            out.append(f"hook {_called(hook, mine)} does not take the arguments of "
                       f"TrackPlugin.{_called(hook, base)}")
    return out


def _plugin_class(name: str) -> tuple[object, str]:
    """What ``name`` is registered as, and where it comes from (for messages)."""
    if name in _registered:
        cls = _registered[name]
        return cls, f"{cls.__module__}:{cls.__qualname__}"
    eps = _entry_points()
    if name not in eps:
        known = sorted({*eps, *_registered})
        hint = difflib.get_close_matches(name, known, n=1)
        did = f" Did you mean {hint[0]!r}?" if hint else ""
        raise PluginError(
            f"no track named {name!r}.{did} Installed: {known or 'none'} "
            f"(tracks register under the entry-point group {GROUP!r}; reinstall with "
            "`pip install -e .` after adding one)"
        )
    try:
        return eps[name].load(), eps[name].value
    except Exception as e:  # noqa: BLE001
        raise PluginError(f"track {name!r}: importing {eps[name].value} failed: {e}") from e


def load_track(name: str) -> TrackPlugin:
    """The plugin registered as ``name``, imported on first use and validated (once)."""
    plugin = _loaded.get(name)
    if plugin is not None:
        return plugin
    cls, where = _plugin_class(name)
    if not (isinstance(cls, type) and issubclass(cls, TrackPlugin)):
        raise PluginError(
            f"track {name!r}: {where} is {cls!r}, not a subclass of plugins.TrackPlugin")
    try:
        plugin = cls()
    except TypeError as e:
        raise PluginError(f"track {name!r}: cannot instantiate {cls.__qualname__}: {e}") from e
    validate_plugin(plugin, name=name)
    with _lock:
        return _loaded.setdefault(name, plugin)
