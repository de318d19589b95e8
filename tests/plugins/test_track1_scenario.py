"""Track 1 scenarios: determinism, the splits, the planned exceptions, tasks, queries and
the step budgets."""

from __future__ import annotations

import re
from collections import Counter

import pytest

from plugins import PluginError, load_track
from plugins.track1 import EXCEPTION_TYPES, Track1Plan, Track1Scenario
from plugins.track1._episode import parse_plan
from plugins.track1._language import SUBSTITUTE_RULE
from simhost.worlds.track1 import HouseSplit, generate_house, initial_ground_truth


def _spec(seed: int, split: str, **params: object) -> Track1Scenario:
    scenario = load_track("track1").make_scenario(seed=seed, split=split, params=params)
    return Track1Scenario.model_validate(scenario.params)


def test_same_seed_same_scenario_and_seeds_differ() -> None:
    assert _spec(11, "standard") == _spec(11, "standard")
    texts = {_spec(s, "standard").task.text for s in range(10)}
    assert len(texts) == 10


def test_splits_follow_design_5() -> None:
    std = [_spec(s, "standard") for s in range(60)]
    ch = [_spec(s, "challenge") for s in range(40)]
    assert {p.rooms for p in std} <= {3, 4, 5} and {p.rooms for p in ch} <= {6, 7, 8}
    with_exc = sum(p.exception is not None for p in std) / len(std)
    assert 0.3 <= with_exc <= 0.7, with_exc  # about half
    assert all(p.exception is not None for p in ch)  # always one
    assert {p.exception.type for p in ch if p.exception} == set(EXCEPTION_TYPES)
    weights = {s: w for s, (w, _) in load_track("track1").splits.items()}
    assert weights["standard"] == 0.6 and weights["challenge"] == 0.4  # equation (2)
    assert {len(p.task.goals) for p in std} == {2}
    assert {len(p.task.goals) for p in ch} == {2, 3}
    # the split's houses and sensing travel with the scenario (replay rebuilds them)
    assert all(isinstance(p.split, HouseSplit) and p.split.name == "standard" for p in std)
    assert std[0].split.config.field_of_view == 120.0
    assert _spec(1, "dev").split.config.field_of_view == 360.0


def test_the_dev_split_keeps_todays_level() -> None:
    place = re.compile(r"^put the \w+ [\w ]+ (in|on) the [\w ]+ in the [\w ]+$")
    use = re.compile(r"^(clean|slice|water) the [\w ]+ with the \w+ [\w ]+$")
    for seed in range(20):
        p = _spec(seed, "dev")
        assert len(p.task.goals) == 1
        assert place.match(p.task.text) or use.match(p.task.text), p.task.text
        assert p.task.substitute_rule == SUBSTITUTE_RULE
        assert p.split.config.reveal_exceptions and p.split.params.distractors == (0, 0)


def test_instructions_have_clauses_paraphrases_and_name_things_unambiguously() -> None:
    verbs: Counter[str] = Counter()
    joins: Counter[str] = Counter()
    for seed in range(60):
        p = _spec(seed, "challenge")
        t = p.task
        assert not re.search(r"\d", t.text), "instructions name things, never ids"
        assert t.substitute_rule == "", "the official splits do not state the substitute rule"
        verbs.update(w for w in ("put", "place", "move", "bring", "clean", "wipe", "slice", "cut",
                                 "water", "use") if re.search(rf"\b{w}\b", t.text))
        joins.update(j for j in (", then ", " and then ", ". After that, ", ", and ")
                     if j in t.text)
        assert len(t.steps) >= 4 * len(t.goals)
        for g in t.goals:
            assert g.fetched != g.destination
            if g.kind == "place":
                assert g.subgoals[-1] == "placed" and ("opened" in g.subgoals) == g.container
            else:
                assert g.subgoals == ("picked", "reached", "used") and g.substitutes
    assert len(verbs) >= 8 and len(joins) == 4, (verbs, joins)


def test_look_alikes_are_told_apart_by_room_or_receptacle() -> None:
    qualified = 0
    for seed in range(40):
        p = _spec(seed, "standard")
        layout = generate_house(seed, params=p.split.params)
        truth = initial_ground_truth(layout)
        names = Counter((o.category, o.colour) for o in truth.objects)
        for g in p.task.goals:
            obj = truth.object(g.fetched)
            assert obj is not None
            if names[(obj.category, obj.colour)] > 1 and f"the {obj.colour}" in p.task.text:
                qualified += 1
    assert qualified > 0


def test_every_exception_fits_its_goal() -> None:
    for seed in range(40):
        p = _spec(seed, "challenge")
        exc = p.exception
        assert exc is not None
        g = p.task.goals[exc.goal]
        if exc.type == "container_unavailable":
            assert g.kind == "place" and g.container and g.substitutes
        elif exc.type == "tool_substitution":
            assert g.kind == "use" and g.substitutes
        elif exc.type == "object_relocation":
            assert g.kind == "place"


def test_queries_are_about_the_whole_house_by_description() -> None:
    kinds: Counter[str] = Counter()
    for seed in range(10):
        p = _spec(seed, "standard")
        for q in p.queries:
            kinds[q.kind] += 1
            assert q.text.endswith("?") and "(id" in q.text or q.kind in (
                "door_state", "container_state", "object_count")
    assert set(kinds) == {"object_room", "door_state", "room_neighbours", "container_state",
                          "tools_for", "object_count"}


def test_step_budgets_follow_the_ground_truth() -> None:
    small = [_spec(s, "standard") for s in range(30)]
    big = [_spec(s, "challenge") for s in range(30)]
    for p in small + big:
        assert set(p.budgets) == {"exploration", "execution"}
        assert 30 < p.budgets["exploration"] < 400 and 40 < p.budgets["execution"] < 800

    def mean(ps: list[Track1Scenario], stage: str) -> float:
        return sum(p.budgets[stage] for p in ps) / len(ps)

    assert mean(big, "exploration") > 1.3 * mean(small, "exploration")
    # the same house gets the same budgets whatever the sensing (an oracle's tour)
    same = {"distractors": [0, 0], "p_in_container": 0.3, "p_container_open": 0.3,
            "room_items": {}}
    dev, std = _spec(5, "dev", step_budgets=True), _spec(5, "standard", house_params=same)
    assert dev.layout_digest == std.layout_digest
    assert std.budgets["exploration"] == dev.budgets["exploration"]
    assert _spec(5, "dev").budgets == {}, "the dev split keeps today's level: no step budgets"


def test_split_parameters_are_checked() -> None:
    plugin = load_track("track1")
    with pytest.raises(PluginError, match="Did you mean 'exceptions'"):
        plugin.make_scenario(seed=1, split="standard", params={"exception": ["door_lock"]})
    with pytest.raises(PluginError, match="exceptions.0: Input should be 'door_lock'"):
        plugin.make_scenario(seed=1, split="standard", params={"exceptions": ["fire"]})
    with pytest.raises(PluginError, match="bad split parameters"):
        plugin.make_scenario(seed=1, split="standard", params={"rooms": [2, 9]})
    with pytest.raises(PluginError, match="field_of_view"):
        plugin.make_scenario(seed=1, split="standard", params={"env": {"field_of_veiw": 90}})
    with pytest.raises(PluginError, match="unknown split"):
        plugin.make_scenario(seed=1, split="standrd", params={})
    only = {_spec(s, "challenge", exceptions=["tool_substitution"]).exception
            for s in range(8)}
    assert {e.type for e in only if e} == {"tool_substitution"}
    assert _spec(3, "standard", exception_probability=0.0).exception is None
    assert _spec(3, "standard", rooms=[7, 7]).rooms == 7
    assert _spec(3, "standard", env={"field_of_view": 90.0}).split.config.field_of_view == 90


def test_plans_are_parsed_leniently() -> None:
    assert parse_plan({}) == (None, "no plan submitted")
    plan, err = parse_plan({"plan": {"subgoals": ["a"], "route": [1, 2], "extra": 1}})
    assert err == "" and plan == Track1Plan(subgoals=["a"], route=[1, 2])
    plan, err = parse_plan({"doors": ["x"]})
    assert plan is None and err.startswith("invalid plan")
