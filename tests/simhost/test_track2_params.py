"""Track 2 instances: sampling determinism, ranges, distance, validation, truth, light import."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from pydantic import ValidationError

from simhost.worlds.track2 import (
    FAMILIES,
    PARAM_TABLES,
    InstanceParams,
    InstanceParamsError,
    TaskTruth,
    VariationConfig,
    default_source,
    instance_distance,
    sample_instance,
    split_config,
    task_truth,
)


@pytest.mark.parametrize("family", FAMILIES)
def test_same_seed_same_instance(family: str) -> None:
    a = sample_instance(family, 11, difficulty=0.7)
    b = sample_instance(family, 11, difficulty=0.7)
    assert a == b
    assert a.model_dump_json() == b.model_dump_json()
    assert sample_instance(family, 12, difficulty=0.7) != a


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("wide", [False, True])
def test_variation_ranges_respected(family: str, wide: bool) -> None:
    specs = PARAM_TABLES[family]
    seen: dict[str, set[object]] = {s.name: set() for s in specs}
    v = VariationConfig(difficulty=1.0, wide=wide)
    for seed in range(60):
        p = sample_instance(family, seed, variation=v)
        for spec in specs:
            value = p.value(spec.name)
            seen[spec.name].add(value)
            if spec.categorical:
                assert value in spec.allowed(wide), (spec.name, value)
            else:
                lo, hi = spec.bounds(wide)
                assert lo <= float(value) <= hi, (spec.name, value)  # type: ignore[arg-type]
    for spec in specs:  # every parameter varies where its range allows, every choice shows up
        if spec.categorical:
            assert seen[spec.name] == set(spec.allowed(wide)), spec.name
        elif spec.bounds(wide)[1] > spec.bounds(wide)[0]:
            assert len(seen[spec.name]) > 30, spec.name


def test_official_splits_have_new_shapes_and_tighter_ranges() -> None:
    wide = VariationConfig(difficulty=1.0, wide=True)
    shapes = {sample_instance("insertion", s, variation=wide).value("shape") for s in range(60)}
    assert "hex" in shapes
    dev = {sample_instance("insertion", s, difficulty=1.0).value("shape") for s in range(60)}
    assert "hex" not in dev
    clearances = [sample_instance("insertion", s, variation=wide).f("clearance")
                  for s in range(60)]
    assert min(clearances) < 0.001 and max(clearances) <= 0.003


def test_official_goals_are_the_demonstrations() -> None:
    v = split_config("challenge").variation
    src = sample_instance("rotation", 4, variation=v.model_copy(update={"goal_from_source": False}))
    flips = 0
    for s in range(40):
        hidden = sample_instance("rotation", s, source=src, variation=v)
        assert hidden.value("turn") == src.value("turn"), "the same turn"
        flips += hidden.value("direction") != src.value("direction")
        assert hidden.value("init_angle") != src.value("init_angle"), "another start"
    assert 5 <= flips <= 30, "the turning direction switches now and then"


@pytest.mark.parametrize("family", FAMILIES)
def test_difficulty_zero_is_the_source_and_distance_grows(family: str) -> None:
    src = sample_instance(family, 5)
    assert sample_instance(family, 9, source=src, difficulty=0.0) == src
    assert instance_distance(src, src) == 0.0
    near = [instance_distance(src, sample_instance(family, s, source=src, difficulty=0.1))
            for s in range(20)]
    far = [instance_distance(src, sample_instance(family, s, source=src, difficulty=1.0))
           for s in range(20)]
    assert all(0.0 <= d <= 1.0 for d in near + far)
    assert sum(near) / len(near) < sum(far) / len(far)
    other = sample_instance(family, 3, source=src, difficulty=1.0)
    assert instance_distance(src, other) == pytest.approx(instance_distance(other, src))


def test_distance_formula_by_hand() -> None:
    a = default_source("insertion")
    geometry = dict(a.geometry, clearance=0.003)  # (0.003 - 0.0025) / 0.0025 = 0.2 of its range
    b = a.model_copy(update={"geometry": geometry})
    # geometry holds 6 parameters: mean 0.2 / 6; weights of present groups sum to 0.85
    assert instance_distance(a, b) == pytest.approx(0.30 * (0.2 / 6) / 0.85)
    assert instance_distance(a, default_source("rotation")) == 1.0


def test_tool_use_mechanism_is_kept_from_the_source_on_dev() -> None:
    mechanisms = {sample_instance("tool_use", s).value("mechanism") for s in range(20)}
    assert mechanisms == {"press", "pull"}
    src = sample_instance("tool_use", 0)
    for s in range(20):
        hidden = sample_instance("tool_use", s, source=src, difficulty=1.0)
        assert hidden.value("mechanism") == src.value("mechanism")
    official = split_config("standard").variation
    switched = sum(sample_instance("tool_use", s, source=src, variation=official)
                   .value("mechanism") != src.value("mechanism") for s in range(60))
    assert 8 <= switched <= 30, "the official splits switch the mechanism now and then"


def test_json_round_trip() -> None:
    p = sample_instance("tool_use", 4)
    again = InstanceParams.model_validate_json(p.model_dump_json())
    assert again == p
    json.loads(p.model_dump_json())


def test_bad_params_say_what_is_wrong() -> None:
    good = default_source("insertion").model_dump()
    bad = dict(good, geometry=dict(good["geometry"], clearence=0.003))
    with pytest.raises(ValidationError, match="Did you mean 'clearance'"):
        InstanceParams.model_validate(bad)
    bad = dict(good, geometry=dict(good["geometry"], clearance=0.5))
    with pytest.raises(ValidationError, match=r"clearance = 0.5 is outside \[0.0005, 0.006\]"):
        InstanceParams.model_validate(bad)
    bad = dict(good, geometry=dict(good["geometry"], shape="hexagon"))
    with pytest.raises(ValidationError, match="choose one of"):
        InstanceParams.model_validate(bad)
    with pytest.raises(InstanceParamsError, match="Did you mean 'rotation'"):
        sample_instance("rotaton", 0)
    with pytest.raises(InstanceParamsError, match="difficulty"):
        sample_instance("rotation", 0, difficulty=1.5)
    with pytest.raises(InstanceParamsError, match="not rotation"):
        sample_instance("rotation", 0, source=default_source("opening"))


@pytest.mark.parametrize("family", FAMILIES)
def test_truth_shape(family: str) -> None:
    for seed in range(6):
        truth = task_truth(sample_instance(family, seed, difficulty=1.0))
        assert isinstance(truth, TaskTruth)
        assert truth.version == "eagc-truth/v2" and truth.family == family
        assert len(truth.stages) == len(set(truth.stages)) >= 4
        assert set(truth.preconditions) <= set(truth.stages)
        names = {v.name for v in truth.state_variables}
        for c in truth.success:
            assert c.op in {">=", "<=", "==", "within"}
            assert c.variable in names
        assert TaskTruth.model_validate_json(truth.model_dump_json()) == truth


def test_truth_states_goals_relative_to_the_start_and_the_splits_tolerance() -> None:
    p = sample_instance("rotation", 3)
    dev, official = task_truth(p), task_truth(p, split_config("standard").bench)
    (turn,) = [c for c in dev.success if c.variable == "knob_turn"]
    sign = 1 if p.value("direction") == "ccw" else -1
    lo, hi = turn.value
    assert (lo + hi) / 2 == pytest.approx(sign * p.f("turn"), abs=1e-5)
    assert hi - lo == pytest.approx(2 * 0.08, abs=1e-5)
    (turn,) = [c for c in official.success if c.variable == "knob_turn"]
    assert turn.value[1] - turn.value[0] == pytest.approx(2 * 0.05, abs=1e-5)
    assert official.constraint("angle_tolerance") == 0.05


def test_light_import_has_no_mujoco() -> None:
    code = (
        "import sys, simhost.worlds.track2 as t\n"
        "t.task_truth(t.sample_instance('assembly', 1))\n"
        "t.read_demo_packet, t.render_attempt_vs_demo\n"
        "assert 'mujoco' not in sys.modules and 'gymnasium' not in sys.modules, sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
