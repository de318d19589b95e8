"""Scripted experts: success rate per family within the step cap, stage order, annotations."""

from __future__ import annotations

import numpy as np
import pytest

from simhost.track2 import (
    FAMILIES,
    BenchEnv,
    InstanceParams,
    ScriptedExpert,
    expert_policy,
    sample_instance,
)


def _episode(params: InstanceParams) -> tuple[bool, list[str], list[dict[str, str]], int]:
    env = BenchEnv(params)
    env.reset(seed=0)
    expert = ScriptedExpert(env)
    stages, events = [], []
    info: dict = {}
    for _ in range(env.max_steps):
        _, _, terminated, truncated, info = env.step(expert())
        assert not info["sim_warnings"], info["sim_warnings"]
        if not stages or stages[-1] != info["stage"]:
            stages.append(info["stage"])
        events += info["events"]
        if terminated or truncated:
            break
    return bool(info["success"]), stages, events, env.steps


def _rate(family: str, seeds: range, difficulty: float) -> float:
    return float(np.mean([_episode(sample_instance(family, s, difficulty=difficulty))[0]
                          for s in seeds]))


@pytest.mark.parametrize("family", FAMILIES)
def test_expert_solves_sampled_instances(family: str) -> None:
    # 6 instances per family: >= 95 % means all of them
    assert _rate(family, range(100, 106), 0.8) >= 0.95


@pytest.mark.slow
@pytest.mark.parametrize("family", FAMILIES)
def test_expert_success_rate_large_sample(family: str) -> None:
    assert _rate(family, range(1000, 1060), 1.0) >= 0.95


@pytest.mark.parametrize("family", FAMILIES)
def test_expert_goes_through_the_stages_in_order(family: str) -> None:
    params = sample_instance(family, 21)
    env = BenchEnv(params)
    env.reset(seed=0)
    order = list(env.task.stages())
    ok, stages, events, steps = _episode(params)
    assert ok and stages[-1] == "done" and steps < env.max_steps
    seen = [order.index(s) for s in stages[:-1]]
    assert seen[0] == 0 and seen[-1] == len(order) - 1
    assert max(seen) == len(order) - 1
    assert any(e["event"] == "grasped" for e in events)


def test_expert_policy_function_follows_episodes() -> None:
    env = BenchEnv(sample_instance("rotation", 4))
    for _ in range(2):  # a new episode restarts the plan
        env.reset(seed=0)
        for _ in range(env.max_steps):
            _, _, terminated, truncated, info = env.step(expert_policy(env))
            if terminated or truncated:
                break
        assert info["success"]
