"""Track 1 scenarios: determinism, the splits, the planned exceptions, tasks and queries."""

from __future__ import annotations

import re

import pytest

from plugins import PluginError, load_track
from plugins.track1 import Track1Plan
from plugins.track1._exceptions import parse_plan
from plugins.track1._scenario import EXCEPTION_TYPES


def _params(seed: int, split: str, **params: object) -> dict:
    return dict(load_track("track1").make_scenario(seed=seed, split=split, params=params).params)


def test_same_seed_same_scenario_and_seeds_differ() -> None:
    assert _params(11, "standard") == _params(11, "standard")
    texts = {_params(s, "standard")["task"]["text"] for s in range(10)}
    assert len(texts) >= 8


def test_splits_follow_design_5() -> None:
    std = [_params(s, "standard") for s in range(60)]
    ch = [_params(s, "challenge") for s in range(30)]
    assert {p["rooms"] for p in std} <= {3, 4, 5} and {p["rooms"] for p in ch} <= {6, 7, 8}
    with_exc = sum(p["exception"] is not None for p in std) / len(std)
    assert 0.3 <= with_exc <= 0.7, with_exc  # about half
    assert all(p["exception"] in EXCEPTION_TYPES for p in ch)  # always one
    assert {p["exception"] for p in ch} == set(EXCEPTION_TYPES)
    weights = {s: w for s, (w, _) in load_track("track1").splits.items()}
    assert weights == {"standard": 0.6, "challenge": 0.4}  # equation (2)


def test_tasks_read_like_alfred_and_fit_their_exception() -> None:
    place = re.compile(r"^(put|place) the \w+ [\w ]+ (in|on) the [\w ]+ in the [\w ]+$")
    use = re.compile(r"^(clean|slice|water) the [\w ]+ with the \w+ [\w ]+$")
    for seed in range(40):
        p = _params(seed, "challenge")
        t, exc = p["task"], p["exception"]
        assert place.match(t["text"]) or use.match(t["text"]), t["text"]
        assert t["steps"] and len(t["subgoals"]) >= 3
        assert not re.search(r"\d", t["text"]), "instructions name things, never ids"
        if exc == "container_unavailable":
            assert t["kind"] == "place" and t["container"] and t["substitutes"]
        elif exc == "tool_substitution":
            assert t["kind"] == "use" and t["substitutes"]
        elif exc == "object_relocation":
            assert t["kind"] == "place"
        elif exc == "door_lock":
            assert t["rooms"][0] != t["rooms"][1]  # the route crosses a door


def test_queries_cover_every_kind() -> None:
    kinds = {q["kind"] for q in _params(4, "standard")["queries"]}
    assert kinds == {"object_room", "door_state", "room_neighbours", "container_state",
                     "tools_for"}


def test_split_parameters_are_checked() -> None:
    plugin = load_track("track1")
    with pytest.raises(PluginError, match="Did you mean 'exceptions'"):
        plugin.make_scenario(seed=1, split="standard", params={"exception": ["door_lock"]})
    with pytest.raises(PluginError, match="unknown exception types"):
        plugin.make_scenario(seed=1, split="standard", params={"exceptions": ["fire"]})
    with pytest.raises(PluginError, match="bad house parameters"):
        plugin.make_scenario(seed=1, split="standard", params={"rooms": [2, 9]})
    only = {_params(s, "challenge", exceptions=["tool_substitution"])["exception"]
            for s in range(8)}
    assert only == {"tool_substitution"}
    none = _params(3, "standard", exception_probability=0.0)
    assert none["exception"] is None
    assert _params(3, "standard", rooms=[7, 7])["rooms"] == 7


def test_plans_are_parsed_leniently() -> None:
    assert parse_plan({}) == (None, "no plan submitted")
    plan, err = parse_plan({"plan": {"subgoals": ["a"], "route": [1, 2], "extra": 1}})
    assert err == "" and plan == Track1Plan(subgoals=["a"], route=[1, 2]).model_dump()
    plan, err = parse_plan({"doors": ["x"]})
    assert plan is None and err.startswith("invalid plan")
