"""Track 2 instances: sampling determinism, ranges, distance, validation, truth, light import."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from pydantic import ValidationError

from simhost.track2 import (
    FAMILIES,
    PARAM_TABLES,
    InstanceParams,
    InstanceParamsError,
    default_source,
    instance_distance,
    sample_instance,
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
def test_variation_ranges_respected(family: str) -> None:
    specs = PARAM_TABLES[family]
    seen: dict[str, set[object]] = {s.name: set() for s in specs}
    for seed in range(60):
        p = sample_instance(family, seed, difficulty=1.0)
        for spec in specs:
            v = p.value(spec.name)
            seen[spec.name].add(v)
            if spec.categorical:
                assert v in spec.choices, (spec.name, v)
            else:
                assert spec.lo <= float(v) <= spec.hi, (spec.name, v)  # type: ignore[arg-type]
    for spec in specs:  # every parameter actually varies, every choice shows up
        if spec.categorical:
            assert seen[spec.name] == set(spec.choices), spec.name
        else:
            assert len(seen[spec.name]) > 30, spec.name


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
    geometry = dict(a.geometry, clearance=0.006)  # (0.006 - 0.004) / 0.004 = 0.5 of its range
    b = a.model_copy(update={"geometry": geometry})
    # geometry holds 6 parameters: mean 0.5 / 6; weights of present groups sum to 0.85
    assert instance_distance(a, b) == pytest.approx(0.30 * (0.5 / 6) / 0.85)
    assert instance_distance(a, default_source("rotation")) == 1.0


def test_tool_use_mechanism_is_kept_from_the_source() -> None:
    mechanisms = {sample_instance("tool_use", s).value("mechanism") for s in range(20)}
    assert mechanisms == {"press", "pull"}
    src = sample_instance("tool_use", 0)
    for s in range(20):
        hidden = sample_instance("tool_use", s, source=src, difficulty=1.0)
        assert hidden.value("mechanism") == src.value("mechanism")


def test_json_round_trip_and_public_view() -> None:
    p = sample_instance("tool_use", 4)
    again = InstanceParams.model_validate_json(p.model_dump_json())
    assert again == p
    pub = p.public()
    assert "friction" not in pub and pub["family"] == "tool_use" and "tools" in pub
    json.dumps(pub)


def test_bad_params_say_what_is_wrong() -> None:
    good = default_source("insertion").model_dump()
    bad = dict(good, geometry=dict(good["geometry"], clearence=0.003))
    with pytest.raises(ValidationError, match="Did you mean 'clearance'"):
        InstanceParams.model_validate(bad)
    bad = dict(good, geometry=dict(good["geometry"], clearance=0.5))
    with pytest.raises(ValidationError, match=r"clearance = 0.5 is outside \[0.002, 0.006\]"):
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
        assert truth["version"] == "eagc-truth/v1" and truth["family"] == family
        assert set(truth) == {"version", "family", "stages", "state_variables", "constraints",
                              "preconditions", "success", "goal"}
        assert len(truth["stages"]) == len(set(truth["stages"])) >= 4
        assert set(truth["preconditions"]) <= set(truth["stages"])
        names = {v["name"] for v in truth["state_variables"]}
        for c in truth["success"]:
            assert c["op"] in {">=", "<=", "==", "within"}
            assert c["variable"] in names
        json.dumps(truth)


def test_light_import_has_no_mujoco() -> None:
    code = (
        "import sys, simhost.track2 as t\n"
        "t.task_truth(t.sample_instance('assembly', 1))\n"
        "t.read_demo_packet, t.render_attempt_vs_demo\n"
        "assert 'mujoco' not in sys.modules and 'gymnasium' not in sys.modules, sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
