"""BenchEnv: gymnasium conformance, spaces, determinism, state, action validation, RGB-D."""

from __future__ import annotations

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from simhost.track2 import (
    FAMILIES,
    BenchEnv,
    InstanceParamsError,
    StateError,
    expert_policy,
    register_envs,
    sample_instance,
)


def _run(env: BenchEnv, actions: np.ndarray) -> list[str]:
    hashes = []
    for a in actions:
        env.step(a)
        hashes.append(env.state_hash())
    return hashes


@pytest.mark.parametrize("family", FAMILIES)
def test_check_env_through_the_registry(family: str) -> None:
    ids = register_envs()
    env_id = f"eagc/Bench-{family.title().replace('_', '')}-v0"
    assert env_id in ids and register_envs() == ids  # idempotent
    env = gym.make(env_id, render_mode="rgb_array", image_size=(48, 64))
    try:
        check_env(env.unwrapped)
        assert isinstance(env.unwrapped, BenchEnv) and env.unwrapped.params.family == family
    finally:
        env.close()


@pytest.mark.parametrize("family", FAMILIES)
def test_observations_stay_in_their_space(family: str) -> None:
    env = BenchEnv(sample_instance(family, 2))
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    assert {"progress", "success", "stage", "contact_force", "sim_warnings"} <= set(info)
    assert info["stage"] == env.task.stages()[0] and not info["success"]
    rng = np.random.default_rng(0)
    for _ in range(25):
        obs, reward, _, _, info = env.step(rng.uniform(-1, 1, 5).astype(np.float32))
        assert env.observation_space.contains(obs)
        assert 0.0 <= info["progress"] <= 1.0 and np.isfinite(reward)


@pytest.mark.parametrize("family", FAMILIES)
def test_same_seed_same_state_hash(family: str) -> None:
    actions = np.random.default_rng(1).uniform(-1, 1, (30, 5)).astype(np.float32)
    a = BenchEnv(sample_instance(family, 7))
    b = BenchEnv(sample_instance(family, 7))  # built separately from the same seed
    a.reset(seed=3)
    b.reset(seed=3)
    assert a.state_hash() == b.state_hash()
    assert _run(a, actions) == _run(b, actions)
    c = BenchEnv(sample_instance(family, 8))
    c.reset(seed=3)
    assert c.state_hash() != a.state_hash()


def test_reset_restores_the_initial_state_exactly() -> None:
    env = BenchEnv(sample_instance("assembly", 3))
    env.reset(seed=0)
    first = env.state_hash()
    actions = np.random.default_rng(2).uniform(-1, 1, (20, 5))
    run1 = _run(env, actions)
    env.reset(seed=0)
    assert env.state_hash() == first
    assert _run(env, actions) == run1


def test_get_state_set_state_continues_bit_exactly() -> None:
    env = BenchEnv(sample_instance("opening", 1))
    env.reset(seed=0)
    for _ in range(15):
        env.step(expert_policy(env))
    saved = env.get_state()
    actions = np.random.default_rng(3).uniform(-1, 1, (15, 5))
    ahead = _run(env, actions)
    env.set_state(saved)
    assert env.get_state() == saved
    assert _run(env, actions) == ahead

    other = BenchEnv(sample_instance("opening", 2))
    with pytest.raises(StateError, match="belongs to instance"):
        other.set_state(saved)
    with pytest.raises(StateError, match="EAGCT2S1"):
        env.set_state(b"garbage")
    with pytest.raises(StateError, match="corrupt|size"):
        env.set_state(saved[:-8] + b"\x00" * 3)


def test_nan_actions_never_reach_mujoco(monkeypatch: pytest.MonkeyPatch) -> None:
    env = BenchEnv(sample_instance("rotation", 0))
    env.reset(seed=0)
    seen: list[np.ndarray] = []
    real_step = mujoco.mj_step

    def spy(m: mujoco.MjModel, d: mujoco.MjData, *args: int) -> None:
        seen.append(d.ctrl.copy())
        real_step(m, d, *args)

    monkeypatch.setattr(mujoco, "mj_step", spy)
    target = env.control_target
    for bad in ([np.nan, 0, 0, 0, 0], [0, np.inf, 0, 0, 0], [0, 0, 0, 0, -np.inf]):
        _, _, _, _, info = env.step(np.array(bad, dtype=np.float32))
        assert info["invalid_action"] and not info["action_clipped"]
        assert np.array_equal(env.control_target, target)  # held still
    _, _, _, _, info = env.step(np.array([3.0, 0, 0, 0, 0], dtype=np.float32))
    assert info["action_clipped"] and not info["invalid_action"]
    assert seen and all(np.all(np.isfinite(c)) for c in seen)
    assert np.all(np.isfinite(env.data.qpos))
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(4, dtype=np.float32))


def test_rgbd_observation() -> None:
    env = BenchEnv(sample_instance("tool_use", 1), render_rgbd=True, image_size=(36, 48))
    obs, _ = env.reset(seed=0)
    assert obs["rgb"].shape == (36, 48, 3) and obs["rgb"].dtype == np.uint8
    assert obs["depth"].shape == (36, 48, 1) and obs["depth"].dtype == np.float32
    assert obs["rgb"].std() > 5  # a real picture, not a blank
    assert 0.2 < float(obs["depth"].min()) < float(obs["depth"].max()) <= 10.0
    assert env.observation_space.contains(obs)
    env.close()


def test_goal_vector_only_when_stated() -> None:
    env = BenchEnv(sample_instance("assembly", 0))
    assert not env.reset(seed=0)[0]["goal"].any()
    env = BenchEnv(sample_instance("rotation", 0))
    goal = env.reset(seed=0)[0]["goal"]
    assert goal[0] == 1.0 and goal[2] > 0


def test_reset_options_switch_instance_within_the_family() -> None:
    env = BenchEnv(family="insertion")
    new = sample_instance("insertion", 8)
    env.reset(options={"params": new})
    assert env.params == new
    with pytest.raises(InstanceParamsError, match="keeps the family"):
        env.reset(options={"params": sample_instance("rotation", 0)})
    with pytest.raises(InstanceParamsError, match="needs params or a family"):
        BenchEnv()


def test_a_dropped_part_is_annotated() -> None:
    env = BenchEnv(sample_instance("insertion", 5))
    env.reset(seed=0)
    events: list[dict[str, str]] = []
    while not any(e["event"] == "lifted" for e in events):
        events += env.step(expert_policy(env))[4]["events"]
    for _ in range(5):  # lift a little higher, then let go
        env.step(np.array([0, 0, 1, 0, -1], dtype=np.float32))
    dropped: list[dict[str, str]] = []
    for _ in range(10):
        dropped += env.step(np.array([0, 0, 0, 0, 1], dtype=np.float32))[4]["events"]
    assert {"event": "released", "part": "peg"} in dropped
    assert {"event": "dropped", "part": "peg"} in dropped
