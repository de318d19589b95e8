"""BenchEnv: gymnasium conformance, spaces, determinism, state, action validation, RGB-D,
and the official splits' observation channel (noise, bias, rate, latency, occlusion, symmetry,
no joint readings, no goal) and per-reset jitter."""

from __future__ import annotations

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from simhost.worlds.track2 import (
    FAMILIES,
    SPLITS,
    BenchEnv,
    InstanceParamsError,
    SplitConfigError,
    StateError,
    default_source,
    env_id,
    expert_policy,
    register_envs,
    sample_instance,
)
from simhost.worlds.track2._bench import yaw_of
from simhost.worlds.track2._observe import canonical_yaw


def _run(env: BenchEnv, actions: np.ndarray) -> list[str]:
    hashes = []
    for a in actions:
        env.step(a)
        hashes.append(env.state_hash())
    return hashes


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("split", ["dev", "standard"])
def test_check_env_through_the_registry(family: str, split: str) -> None:
    ids = register_envs()
    assert env_id(family) in ids and register_envs() == ids  # idempotent
    env = gym.make(env_id(family), render_mode="rgb_array", image_size=(48, 64), split=split,
                   instance_seed=3)
    try:
        check_env(env.unwrapped)
        base = env.unwrapped
        assert isinstance(base, BenchEnv) and base.params.family == family
        assert base.config == SPLITS[split].bench.model_copy(update={
            "observation": base.config.observation.model_copy(update={"image_size": (48, 64)})})
        assert ("goal" in base.observation_space.spaces) == (split == "dev")
        assert ("rgb" in base.observation_space.spaces) == (split != "dev")
    finally:
        env.close()


def test_unknown_split_says_which_exist() -> None:
    with pytest.raises(SplitConfigError, match="Did you mean 'standard'"):
        BenchEnv(family="rotation", split="standrd")


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("split", ["dev", "challenge"])
def test_observations_stay_in_their_space(family: str, split: str) -> None:
    env = BenchEnv(sample_instance(family, 2), split=split)
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
    env = BenchEnv(sample_instance("opening", 1), split="standard")
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
    with pytest.raises(StateError, match="EAGCT2S2"):
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
    assert obs["depth"].shape == (36, 48) and obs["depth"].dtype == np.float32
    assert obs["rgb"].std() > 5  # a real picture, not a blank
    assert 0.2 < float(obs["depth"].min()) < float(obs["depth"].max()) <= 10.0
    assert env.observation_space.contains(obs)
    env.close()


def test_rgbd_only_with_segmentation() -> None:
    from simhost.worlds.track2 import split_config

    bench = split_config("standard").bench
    cfg = bench.model_copy(update={"observation": bench.observation.model_copy(
        update={"parts": False, "segmentation": True, "image_size": (48, 64)})})
    env = BenchEnv(sample_instance("insertion", 1), config=cfg)
    obs, _ = env.reset(seed=0)
    assert "parts" not in obs and {"rgb", "depth", "segmentation"} <= set(obs)
    seg = obs["segmentation"]
    assert seg.shape == (48, 64) and seg.dtype == np.int32 and env.observation_space.contains(obs)
    assert {1, 2} <= set(np.unique(seg).tolist()), "the peg and the hole are in view"
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


def _measured(env: BenchEnv, obs: dict, row: int) -> tuple[np.ndarray, float]:
    r = obs["parts"][row]
    return r[1:4].astype(float), yaw_of(r[4:8].astype(float))


def test_official_channel_is_noisy_biased_delayed_and_slower() -> None:
    env = BenchEnv(default_source("insertion"), split="standard")
    cfg = env.config.observation
    assert cfg.period_steps == 2 and cfg.latency_steps == 1 and not cfg.joint_readings
    errors, ages = [], []
    obs, _ = env.reset(seed=4, options={"bias_seed": 9})
    for k in range(200):
        prev = obs["parts"].copy()
        obs, *_ = env.step(np.zeros(5, np.float32))  # nothing moves: the hole stays put
        pos, _ = _measured(env, obs, 1)
        errors.append(pos - env.task.parts()[1, 1:4])
        ages.append(float(obs["parts"][1, 9]))
        if k % 2 == 0:  # measured every 2 steps only: in between the row stays as it was
            assert np.array_equal(obs["parts"][:, :9], prev[:, :9])
    err = np.asarray(errors)
    assert 0.0003 < float(err[:, 0].std()) < 0.003, "about a millimetre of noise"
    assert np.all(np.isin(np.round(np.asarray(ages) * 20), [1, 2])), "latency 1, period 2"
    assert float(np.abs(err).max()) < 0.02
    # the bias stays for the episode: the same bias seed, the same mean error
    again = BenchEnv(default_source("insertion"), split="standard")
    obs2, _ = again.reset(seed=5, options={"bias_seed": 9})
    errs2 = []
    for _ in range(200):
        obs2, *_ = again.step(np.zeros(5, np.float32))
        errs2.append(_measured(again, obs2, 1)[0] - again.task.parts()[1, 1:4])
    assert np.allclose(err.mean(axis=0), np.asarray(errs2).mean(axis=0), atol=0.0008)
    assert not np.array_equal(err, np.asarray(errs2)), "new noise for another reset seed"
    assert np.all(obs["parts"][:, 8] == 0.0) and "goal" not in obs


def test_symmetric_parts_report_yaw_modulo_their_symmetry() -> None:
    src = default_source("insertion")
    params = src.model_copy(update={"geometry": {**src.geometry, "shape": "hex"},
                                    "pose": {**src.pose, "peg_yaw": 0.7}})
    env = BenchEnv(params, split="standard")
    obs, _ = env.reset(seed=0)
    _, yaw = _measured(env, obs, 0)
    period = np.pi / 3
    assert -period / 2 - 0.1 <= yaw <= period / 2 + 0.1
    assert abs(canonical_yaw(0.7, period) - yaw) < 0.15
    dev = BenchEnv(params)
    assert abs(_measured(dev, dev.reset(seed=0)[0], 0)[1] - 0.7) < 1e-6


def test_a_handle_with_a_pointer_shows_its_angle_over_a_full_turn() -> None:
    src = default_source("rotation")
    for kind in ("knob", "valve", "nut"):
        params = src.model_copy(update={"geometry": {**src.geometry, "kind": kind},
                                        "pose": {**src.pose, "init_angle": 1.3}})
        env = BenchEnv(params, split="standard")
        _, yaw = _measured(env, env.reset(seed=0)[0], 0)
        assert abs(yaw - 1.3) < 0.15, kind  # not folded by the handle's shape


def test_the_calibration_error_is_common_to_every_part() -> None:
    env = BenchEnv(default_source("insertion"), split="standard")
    obs, _ = env.reset(seed=1, options={"bias_seed": 3})
    truth = env.task.parts()
    seen, rel = [], []
    for _ in range(100):
        obs, *_ = env.step(np.zeros(5, np.float32))
        err = obs["parts"][:2, 1:3].astype(float) - truth[:2, 1:3]
        seen.append(err)
        rel.append(err[0] - err[1])
    seen_mean, rel_mean = np.mean(seen, axis=0), np.mean(rel, axis=0)
    # the same episode error on both parts, which a relative measurement cancels
    assert np.linalg.norm(seen_mean[0]) > 0.002 and np.linalg.norm(seen_mean[1]) > 0.002
    assert np.linalg.norm(rel_mean) < 0.5 * min(np.linalg.norm(seen_mean, axis=1))


def test_a_part_the_gripper_hides_keeps_its_last_measurement() -> None:
    # the knob's bar along y: the hand grasping it turns across both cameras' views (they
    # look along x from either side of the table) and its palm hides the knob from both
    src = default_source("rotation")
    src = src.model_copy(update={"pose": {**src.pose, "init_angle": 1.5}})
    env = BenchEnv(src, split="standard")
    obs, _ = env.reset(seed=0)
    ages, stale = [], 0
    for _ in range(60):
        prev = obs["parts"][0].copy()
        obs, _, _, _, info = env.step(expert_policy(env))
        ages.append(float(obs["parts"][0, 9]))
        if ages[-1] > 0.3:  # hidden: the row still shows its last measurement
            assert np.array_equal(obs["parts"][0, :9], prev[:9])
            stale += 1
    assert stale >= 5, "the knob was hidden under the grasping hand for a while"
    assert min(ages) < 0.06  # fresh: only the latency (one step) old


def test_every_reset_jitters_the_parts_from_its_seed() -> None:
    env = BenchEnv(default_source("assembly"), split="standard")
    env.reset(seed=1)
    a = env.task.parts()[:, 1:3].copy()
    env.reset(seed=1)
    assert np.array_equal(a, env.task.parts()[:, 1:3]), "same seed, same jitter"
    env.reset(seed=2)
    moved = np.linalg.norm(env.task.parts()[:, 1:3] - a, axis=1)
    assert 0.0005 < float(moved[:3].max()) < 0.02
    dev = BenchEnv(default_source("assembly"))
    dev.reset(seed=1)
    b = dev.task.parts()[:, 1:3].copy()
    dev.reset(seed=2)
    assert np.array_equal(b, dev.task.parts()[:, 1:3]), "dev: exactly the same state"
