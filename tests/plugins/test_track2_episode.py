"""Track 2 scenarios (balanced families, feasible instances), the demonstration packet, stages
and the attempt rules (real MuJoCo)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from plugins import PluginError, Scenario, load_track
from plugins.track2 import Track2Episode
from simhost.worlds.track2 import (
    FAMILIES,
    ScriptedExpert,
    instance_distance,
    read_demo_packet,
)

TRACK = load_track("track2")
HOLD = np.array([0.0, 0.0, 0.0, 0.0, 1.0], dtype=np.float32)


def make(seed: int = 0, split: str = "standard", index: int | None = None,
         **params: Any) -> Scenario:
    return TRACK.make_scenario(seed=seed, split=split, params={"demo_frames": False, **params},
                               index=index)


def start(scenario: Scenario) -> Track2Episode:
    """An episode brought to the start of execution the way the host does it."""
    ep = TRACK.make_episode(scenario)
    assert isinstance(ep, Track2Episode)
    ep.reset()
    for stage in ("demonstration", "parsing"):
        ep.on_stage_start(stage)
        ep.on_stage_end(stage, ended_by="agent", payload={})
    ep.on_stage_start("execution")
    return ep


def test_stages_follow_table_v() -> None:
    stages = TRACK.stages()
    assert [(s.name, s.budget_s / 60, s.allows_motion) for s in stages] == [
        ("demonstration", 5, False), ("parsing", 20, False), ("execution", 30, True)]


def test_families_balance_by_index_and_scenarios_are_deterministic() -> None:
    assert [make(100 + i, index=i).params["family"] for i in range(5)] == list(FAMILIES)
    assert [make(seed).params["family"] for seed in range(5)] == list(FAMILIES)
    a, b = make(7), make(7)
    assert a.params == b.params
    s = TRACK.hidden(a)
    assert s.distance == pytest.approx(instance_distance(s.source, s.instance), abs=1e-6)
    assert s.source.family == s.instance.family == s.family and s.source != s.instance
    assert make(3, family="rotation").params["family"] == "rotation"


def test_hidden_instances_are_feasible_through_the_observation_channel() -> None:
    from simhost.worlds.track2 import family_step_cap

    for i in range(5):
        s = TRACK.hidden(make(300 + i, "challenge", index=i))
        assert s.expert_steps is not None and s.expert_steps <= s.attempt_steps, s.family
        assert s.expert_attempt is not None and 1 <= s.expert_attempt <= s.max_attempts
        assert 1 <= s.draws <= 8
        assert not s.bench.observation.joint_readings and not s.bench.observation.goal_vector
        # the budget: twice what the feasibility expert needed, within the family's cap
        assert s.attempt_steps == min(family_step_cap(s.family), 2 * s.expert_steps)
        dev = TRACK.hidden(make(300 + i, "dev", index=i))
        assert dev.attempt_steps == family_step_cap(dev.family)  # dev: today's caps


def test_official_goals_come_from_the_demonstration() -> None:
    s = TRACK.hidden(make(11, "standard", index=1))  # rotation
    assert s.instance.value("turn") == s.source.value("turn")
    assert s.preset == "standard" and s.bench.tolerances.rotation_rad == 0.05
    dev = TRACK.hidden(make(11, "dev", index=1))
    assert dev.bench.observation.goal_vector and dev.bench.tolerances.rotation_rad == 0.08


def test_challenge_instances_lie_farther_from_the_demonstration() -> None:
    seeds = range(10)
    std = np.mean([make(s, "standard").params["distance"] for s in seeds])
    ch = np.mean([make(s, "challenge").params["distance"] for s in seeds])
    assert ch > std + 0.03


def test_bad_scenario_parameters_say_what_is_wrong() -> None:
    with pytest.raises(PluginError, match="Did you mean 'difficulty'"):
        TRACK.make_scenario(seed=1, split="standard", params={"dificulty": 0.3})
    with pytest.raises(PluginError, match=r"difficulty must be a number in \[0, 1\]"):
        TRACK.make_scenario(seed=1, split="standard", params={"difficulty": 2})
    with pytest.raises(PluginError, match="Did you mean 'tool_use'"):
        TRACK.make_scenario(seed=1, split="standard", params={"family": "tooluse"})
    with pytest.raises(PluginError, match="Did you mean 'standard'"):
        TRACK.make_scenario(seed=1, split="standrd", params={})
    s = TRACK.make_scenario(seed=1, split="qualification", params={"preset": "challenge",
                                                                    "demo_frames": False})
    assert s.params["preset"] == "challenge" and s.split == "qualification"


def test_split_parameters_are_one_typed_model() -> None:
    from plugins.track2 import Track2SplitParams
    from plugins.track2._scenario import split_params

    preset, sp = split_params("qualification", {"preset": "challenge", "max_attempts": 2,
                                                "difficulty": 1, "rgbd_only": True})
    assert preset == "challenge" and isinstance(sp, Track2SplitParams)
    assert (sp.max_attempts, sp.difficulty, sp.rgbd_only, sp.demo_frames) == (2, 1.0, True, True)
    for params, says in (({"max_attempts": 4}, r"max_attempts must be an integer in \[1, 3\]"),
                         ({"attempt_steps": True}, "attempt_steps must be an integer"),
                         ({"demo_frames": "no"}, "demo_frames must be true or false"),
                         ({"source_spread": float("nan")}, "source_spread must be a number")):
        with pytest.raises(PluginError, match=says):
            split_params("standard", params)
    s = TRACK.hidden(TRACK.make_scenario(seed=1, split="standard", index=0, params={
        "max_attempts": 2, "attempt_steps": 40, "demo_frames": False}))
    assert (s.max_attempts, s.attempt_steps, s.demo_frames) == (2, 40, False)


def test_write_inputs_writes_the_source_demonstration(tmp_path: Path) -> None:
    s = make(4)
    TRACK.write_inputs(s, tmp_path)
    packet = read_demo_packet(tmp_path / "demo")
    man = packet.manifest
    hidden = TRACK.hidden(s)
    assert man.success and man.family == hidden.family and man.version == "eagc-demo/v2"
    assert "goal" not in man.observation_spec, "the official packet states no goal"
    assert hidden.instance != hidden.source


def test_rgbd_only_offers_images_and_no_parts() -> None:
    ep = TRACK.make_episode(make(2, rgbd_only=True))
    try:
        names = {f.name for f in ep.observation_spec}
        assert {"rgb", "depth", "segmentation"} <= names and "parts" not in names
        obs = ep.reset()
        assert obs.tensors["segmentation"].dtype == np.int32
    finally:
        ep.close()


def test_nothing_moves_before_execution() -> None:
    ep = TRACK.make_episode(make(0))
    try:
        ep.reset()
        before = ep.state_hash()
        for stage in ("demonstration", "parsing"):
            messages = ep.on_stage_start(stage)
            if stage == "demonstration":
                demo = [m for m in messages if m.type == "demonstration"]
                assert demo and demo[0].data["path"] == "/input/demo"
                assert "EAGC_INPUT" in demo[0].data["hint"]
            out = ep.step(stage, {"motion": np.ones(5, np.float32)})
            assert out.action is not None and not out.action.applied and not out.action.ok
            assert "nothing moves" in out.action.reason
            ep.on_stage_end(stage, ended_by="agent", payload={})
        assert ep.state_hash() == before
        assert ep.outcome().refused == 2
    finally:
        ep.close()


def test_attempts_reset_the_instance_and_report_their_outcome() -> None:
    ep = start(make(0))
    try:
        initial = ep.state_hash()
        for _ in range(5):
            out = ep.step("execution", {"motion": np.array([1, 0, -1, 0.5, -1], np.float32)})
        cap = ep.cap
        assert ep.state_hash() != initial
        assert out.observation.data["attempt_steps_left"] == cap - 5
        out = ep.step("execution", {"end_attempt": 1, "motion": HOLD})
        assert out.action is not None and out.action.ok and not out.action.applied
        (msg,) = [m for m in out.messages if m.type == "attempt_result"]
        assert msg.data == {"attempt": 1, "success": False, "ended_by": "agent", "steps": 5,
                            "attempts_left": 2}
        assert out.observation.data == {"attempt": 2, "attempts_left": 1,
                                        "attempt_steps_left": cap}
        assert ep.state_hash() != initial, "a new attempt: reset, with its own jitter"
        assert ep.step_budget("execution") == 3 * (cap + 1)
        assert ep.step_budget("parsing") is None
        poses = ep.poses()
        assert {"tcp", "peg", "hole"} <= set(poses)
        assert not out.episode_over
        out = ep.step("execution", {"end_attempt": 1})
        assert not out.episode_over and out.observation.data["attempt"] == 3
        out = ep.step("execution", {})
        assert out.action is not None and not out.action.ok and "motion" in out.action.reason
        out = ep.step("execution", {"end_attempt": 1})
        assert out.episode_over and out.end_reason == "attempts_used"
        o = ep.outcome()
        assert [a.ended_by for a in o.attempts] == ["agent"] * 3
        assert [a.steps for a in o.attempts] == [5, 0, 0]
        assert not o.success and o.success_attempt is None and o.steps == 5
    finally:
        ep.close()


def test_step_cap_ends_an_attempt_and_success_ends_the_episode() -> None:
    ep = start(make(1, attempt_steps=6))
    try:
        outs = [ep.step("execution", {"motion": HOLD}) for _ in range(6)]
        assert not any(o.messages for o in outs[:5])
        out = outs[-1]
        assert out.action is not None and out.action.applied
        assert out.messages[0].data == {"attempt": 1, "success": False, "ended_by": "step_cap",
                                        "steps": 6, "attempts_left": 2}
        assert out.observation.data["attempt"] == 2
    finally:
        ep.close()

    ep = start(make(1))  # a rotation: the observation expert solves it on attempt 2
    try:
        out = ep.step("execution", {"end_attempt": 1})
        obs = dict(out.observation.tensors)
        expert = ScriptedExpert(ep.env, observed=True, obs=obs)
        for _ in range(300):
            out = ep.step("execution", {"motion": expert(obs)})
            obs = dict(out.observation.tensors)
            if out.episode_over:
                break
        assert out.episode_over and out.end_reason == "success"
        assert out.messages[0].data["success"] is True
        o = ep.outcome()
        assert o.success_attempt == 2 and o.attempts[1].peak_progress == 1.0
        assert [a.ended_by for a in o.attempts] == ["agent", "success"]
        assert o.drops == 0 and o.excess_force_steps == 0
        events = ep.on_stage_end("execution", ended_by="episode_over", payload={})
        assert events == ()
    finally:
        ep.close()


def test_a_stage_budget_ends_the_attempt_under_way() -> None:
    ep = start(make(2))
    try:
        ep.step("execution", {"motion": HOLD})
        (event,) = ep.on_stage_end("execution", ended_by="budget", payload={})
        assert event["event"] == "attempt_end" and event["ended_by"] == "stage_budget"
        assert ep.outcome().attempts[0].steps == 1
    finally:
        ep.close()
