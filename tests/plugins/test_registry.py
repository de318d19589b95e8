"""Finding track plugins by entry point, lazily, with errors that say what to do."""

from __future__ import annotations

import sys
from importlib.metadata import EntryPoint

import pytest

from plugins import (
    GROUP,
    PluginError,
    StageSpec,
    TrackPlugin,
    _registry,
    available_tracks,
    load_track,
    validate_plugin,
)
from plugins.sanity import SanityTrack


def test_sanity_is_installed_and_loads():
    assert "sanity" in available_tracks()
    plugin = load_track("sanity")
    assert isinstance(plugin, SanityTrack)
    assert load_track("sanity") is plugin  # loaded once


def test_unknown_track_suggests_the_closest_name():
    with pytest.raises(PluginError) as e:
        load_track("sanitty")
    text = str(e.value)
    assert "no track named 'sanitty'" in text
    assert "Did you mean 'sanity'?" in text
    assert GROUP in text and "'sanity'" in text


def test_unknown_track_without_a_close_name():
    with pytest.raises(PluginError) as e:
        load_track("zzzzzzzz")
    assert "Did you mean" not in str(e.value) and "Installed:" in str(e.value)


# ---------------------------------------------------------------- plugin validation
def _bad(**attrs: object) -> SanityTrack:
    return type("BadTrack", (SanityTrack,), attrs)()


@pytest.mark.parametrize(
    ("attrs", "problem"),
    [
        ({"weights": {"task": 0.5, "model": 0.2}}, "weights sum to 0.7"),
        ({"splits": {}}, "no splits"),
        ({"stages": lambda self: []}, "stages() is empty"),
        ({"stages": lambda self: [StageSpec("a", 1.0), StageSpec("a", 2.0)]},
         "stage names repeat: ['a', 'a']"),
        ({"stages": lambda self: [StageSpec("a", 0.0)]}, "stage 'a' has budget 0.0"),
        ({"stages": lambda self: 1 / 0}, "stages() raised ZeroDivisionError"),
    ],
    ids=["weights", "splits", "no stages", "repeated stage", "zero budget", "stages raise"],
)
def test_validation_names_the_plugin_and_the_problem(attrs, problem):
    with pytest.raises(PluginError) as e:
        validate_plugin(_bad(**attrs), name="sanity")
    text = str(e.value)
    assert "track plugin 'sanity'" in text and "BadTrack" in text
    assert problem in text


def test_validation_checks_the_scenario_and_outcome_models():
    with pytest.raises(PluginError) as e:
        validate_plugin(_bad(scenario_model=dict, outcome_model=SanityTrack.scenario_model),
                        name="sanity")
    text = str(e.value)
    assert "scenario_model is <class 'dict'>, not a subclass of pydantic.BaseModel" in text
    assert "outcome_model is <class 'plugins.sanity._track.SanityScenario'>, not a subclass " \
        "of plugins.EpisodeOutcome" in text


def test_validation_lists_every_problem_at_once():
    plugin = _bad(name="other", weights={"task": 2.0}, splits={})
    with pytest.raises(PluginError) as e:
        validate_plugin(plugin, name="sanity")
    text = str(e.value)
    assert "registered as 'sanity'" in text and "weights sum to 2.0" in text
    assert "no splits" in text


def test_missing_class_attribute():
    class NoTitle(TrackPlugin):
        name = "sanity"
        weights = SanityTrack.weights
        files = SanityTrack.files
        splits = SanityTrack.splits
        stages = SanityTrack.stages
        make_scenario = SanityTrack.make_scenario
        make_episode = SanityTrack.make_episode
        score = SanityTrack.score

    with pytest.raises(PluginError, match=r"NoTitle\): class attribute 'title' is missing"):
        validate_plugin(NoTitle(), name="sanity")


# ------------------------------------------------------------ broken entry points
@pytest.fixture
def entry_points(monkeypatch, tmp_path):
    """Adds entry points (name → 'module:attr') next to the installed ones."""
    module = tmp_path / "eagc_test_tracks.py"
    module.write_text(
        "from plugins.sanity import SanityTrack\n"
        "class WrongWeights(SanityTrack):\n"
        "    name = 'wrong-weights'\n"
        "    weights = {'task': 1.5}\n"
        "class NeedsArgs(SanityTrack):\n"
        "    def __init__(self, config):\n"
        "        pass\n"
        "NOT_A_CLASS = 42\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    installed = _registry._entry_points()
    extra: dict[str, EntryPoint] = {}

    def add(name: str, value: str) -> None:
        extra[name] = EntryPoint(name=name, value=value, group=GROUP)

    monkeypatch.setattr(_registry, "_entry_points", lambda: {**installed, **extra})
    yield add
    sys.modules.pop("eagc_test_tracks", None)


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("eagc_test_tracks:WrongWeights", "weights sum to 1.5"),
        ("eagc_test_tracks:NOT_A_CLASS", "is 42, not a subclass of plugins.TrackPlugin"),
        ("eagc_test_tracks:NeedsArgs", "cannot instantiate NeedsArgs"),
        ("eagc_no_such_module:Track", "importing eagc_no_such_module:Track failed"),
    ],
    ids=["fails validation", "not a plugin", "needs arguments", "import fails"],
)
def test_broken_entry_point(entry_points, value, message):
    entry_points("wrong-weights", value)
    with pytest.raises(PluginError) as e:
        load_track("wrong-weights")
    assert "'wrong-weights'" in str(e.value)
    assert message in str(e.value)
