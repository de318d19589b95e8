"""What the robot perceives on each split: field of view, noise, misses, confusion, odometry
drift, room signs and exceptions that show only through their effects; all of it seeded."""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterator
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from simhost.worlds.track1 import (
    CONFUSABLE,
    CONFUSABLE_COLOURS,
    ENV_IDS,
    SPLITS,
    ConfigError,
    HouseEnv,
    house_split,
    make_action,
)


def _dets(info: dict[str, Any]) -> dict[int, dict[str, Any]]:
    return {d["id"]: d for d in info["detections"]}


def _wander(env: HouseEnv, n: int, seed: int = 0) -> list[tuple[dict, dict, tuple]]:
    """Drives around: toward the freest direction within 90 degrees of ahead (by the range
    scan, with seeded jitter). Returns (observation, info, true pose) per step."""
    rng = np.random.default_rng(seed)
    out = []
    obs = env.observe()[0]
    for _ in range(n):
        scan = obs["range_scan"]
        rays = len(scan)
        options = [k % rays for k in range(-rays // 4, rays // 4 + 1)]
        k = max(options, key=lambda k: scan[k] + rng.uniform(0, 1.5))
        turn = math.remainder(2 * math.pi * k / rays, math.tau) / (math.pi / 4)
        forward = float(np.clip((scan[k] - 0.7) / 0.5, 0.0, 1.0))
        obs, _r, _t, _tr, info = env.step(make_action(
            "move", forward=forward, turn=float(np.clip(turn, -1, 1))))
        out.append((obs, info, env.house.robot_pose))  # type: ignore[union-attr]
    return out


@pytest.mark.parametrize("split", sorted(SPLITS))
def test_every_split_id_makes_a_checked_env(split: str) -> None:
    env = gym.make(ENV_IDS[split])
    check_env(env.unwrapped, skip_render_check=True)
    assert env.unwrapped.config == house_split(split).config
    env.close()


def test_unknown_split_suggests_the_right_name() -> None:
    with pytest.raises(ConfigError, match="did you mean 'standard'"):
        HouseEnv(split="standrd")


def test_field_of_view_and_range_limit_what_is_seen() -> None:
    dev = HouseEnv(split="dev")
    dev.reset(seed=5)
    robot = HouseEnv(split="standard", position_noise=(0.0, 0.0), miss_rate=(0.0, 0.0),
                     category_confusion=0.0, colour_confusion=0.0, render_rgbd=False)
    robot.reset(seed=5)
    seen_all, seen_ahead = set(), set()
    for k in range(8):  # a full turn on the spot
        _o, _r, _t, _tr, info = dev.step(make_action("move", turn=1.0))
        seen_all |= set(_dets(info))
        _o, _r, _t, _tr, info = robot.step(make_action("move", turn=1.0))
        seen_ahead |= set(_dets(info))
        for d in info["detections"]:
            x, y = d["rel_pos"]
            assert abs(math.atan2(y, x)) <= math.radians(60) + 1e-6, (k, d)
            assert math.hypot(x, y) <= 5.0 + 1e-6
    assert seen_ahead <= seen_all


def test_noise_misses_and_confusion_are_seeded_and_grow_with_distance() -> None:
    def play(seed: int) -> list[tuple[dict, dict, tuple]]:
        env = HouseEnv(split="standard", render_rgbd=False)
        env.reset(seed=seed)
        return _wander(env, 60, seed=1)

    a, b = play(11), play(11)
    for (oa, ia, _pa), (ob, ib, _pb) in zip(a, b, strict=True):
        assert ia["detections"] == ib["detections"]
        assert np.array_equal(oa["odometry"], ob["odometry"])
    c = play(12)
    assert [i["detections"] for _, i, _ in c] != [i["detections"] for _, i, _ in a]


def _tour(env: HouseEnv) -> list[tuple[float, float, float]]:
    """Collision-free poses all over the house: every furniture's access pose, facing it and
    turned by +-90 degrees."""
    return [(f.access[0], f.access[1], f.access[2] + turn)
            for f in env.layout.furniture for turn in (0.0, math.pi / 2, -math.pi / 2)]


def _looks(env: HouseEnv) -> Iterator[tuple[dict[int, Any], list[Any]]]:
    """At every pose of the tour: the exact entities in view (by id) and what the detector
    reports of them."""
    house = env.house
    assert house is not None
    for pose in _tour(env):
        env.teleport_robot(*pose)
        env.step(make_action("noop"))
        yield {d.id: d for d in house.visible()}, house.detections()


def test_detector_model_against_the_truth() -> None:
    env = HouseEnv(split="challenge", render_rgbd=False)
    env.reset(seed=3)
    errors: list[tuple[float, float]] = []
    shown = missed = 0
    confused: Counter[str] = Counter()
    for exact, reported in _looks(env):
        for d in reported:
            t = exact[d.id]
            errors.append((t.distance, math.dist(d.rel_pos, t.rel_pos)))
            if d.category != t.category:
                assert d.category in CONFUSABLE[t.category]
                confused["category"] += 1
            if d.colour != t.colour:
                assert d.colour in CONFUSABLE_COLOURS[t.colour]
                confused["colour"] += 1
        shown += len(reported)
        missed += len(exact) - len(reported)
    near = [e for d, e in errors if d < 1.5]
    far = [e for d, e in errors if d > 3.0]
    assert len(near) > 20 and len(far) > 20
    assert np.mean(far) > 1.5 * np.mean(near) > 0
    assert 0.02 < missed / (missed + shown) < 0.4
    assert confused["category"] > 0 and confused["colour"] > 0


def test_look_alikes_repeat_from_afar_and_read_right_up_close() -> None:
    """A confusable thing reads as the same look-alike every time it is seen from beyond its
    own distance, and right from within ``confusion_beyond[0]``: looking again from afar
    does not correct it, a closer look does."""
    lo, _hi = house_split("challenge").config.confusion_beyond
    env = HouseEnv(split="challenge", render_rgbd=False, miss_rate=(0.0, 0.0),
                   position_noise=(0.0, 0.0))
    env.reset(seed=4)
    categories: dict[int, set[str]] = {}
    colours: dict[int, set[str]] = {}
    wrong_far: Counter[int] = Counter()
    for exact, reported in _looks(env):
        for d in reported:
            t = exact[d.id]
            if (d.category, d.colour) != (t.category, t.colour):
                assert t.distance > lo, (t, d)  # never wrong up close
                wrong_far[d.id] += 1
            categories.setdefault(d.id, set()).add(d.category)
            colours.setdefault(d.id, set()).add(d.colour)
    assert wrong_far, "some things read as a look-alike from afar"
    for k in wrong_far:  # the same look-alike every time (besides the right reading)
        assert len(categories[k]) <= 2 and len(colours[k]) <= 2, (categories[k], colours[k])
    items = [i.id for i in env.layout.items if i.id in categories]
    share = sum(1 for i in items if i in wrong_far) / len(items)
    assert 0.05 < share < 0.6, share


def test_odometry_drifts_but_dev_odometry_is_exact() -> None:
    dev = HouseEnv(split="dev")
    dev.reset(seed=2)
    robot = HouseEnv(split="standard", render_rgbd=False)
    robot.reset(seed=2)
    drift = []
    for env in (dev, robot):
        for obs, _info, (x, y, _yaw) in _wander(env, 80, seed=3):
            drift.append((env is robot, math.dist(obs["odometry"][:2], (x, y))))
    assert max(d for r, d in drift if not r) < 1e-3
    ahead = [d for r, d in drift if r]
    assert ahead[-1] > 0.01 and max(ahead) < 2.0


def test_the_room_is_read_from_a_sign_on_entry() -> None:
    env = HouseEnv(split="standard", render_rgbd=False)
    obs, info = env.reset(seed=7)
    assert obs["room"][0] == env.layout.start_room == info["room"]["id"]
    obs = env.step(make_action("noop"))[0]
    assert obs["room"][0] == -1 and obs["room_type"][0] == -1
    last = env.layout.start_room
    for pose in _tour(env):
        env.teleport_robot(*pose)
        obs, _r, _t, _tr, info = env.step(make_action("noop"))
        here = env.layout.room_at(pose[0], pose[1])
        if here != last:
            assert obs["room"][0] == here and info["room"]["type"] == env.layout.rooms[here].type
        else:
            assert obs["room"][0] == -1 and info["room"]["id"] == -1
        last = here
    dev = HouseEnv(split="dev")
    dev.reset(seed=7)
    for _ in range(3):
        assert dev.step(make_action("noop"))[0]["room"][0] == dev.layout.start_room


def test_exceptions_show_only_through_their_effects_on_official_splits() -> None:
    env = HouseEnv(split="standard", render_rgbd=False, miss_rate=(0.0, 0.0),
                   category_confusion=0.0, colour_confusion=0.0)
    env.reset(seed=6)
    layout = env.layout
    door = layout.doors[0]
    side = next(r for r in door.rooms if r != door.swing_room)
    env.lock_door(door.id)
    env.teleport_robot(*door.approach(side))
    info = env.step(make_action("noop"))[4]
    assert _dets(info)[door.id]["state"] == "closed", "a locked door looks closed"
    info = env.step(make_action("open", target=door.id))[4]
    assert info["action_result"]["reason"] == "locked"
    box = next(f for f in layout.furniture if f.kind == "container" and f.opening == "front")
    env.teleport_robot(*box.access)
    before = _dets(env.step(make_action("noop"))[4])[box.id]["state"]
    env.make_container_unavailable(box.id)
    info = env.step(make_action("noop"))[4]
    assert _dets(info)[box.id]["state"] == before, "an unavailable container looks as before"
    primitive = "open" if before == "closed" else "close"
    info = env.step(make_action(primitive, target=box.id))[4]
    assert info["action_result"]["reason"] == "unavailable"
    assert env.ground_truth().containers[0].state in ("open", "closed", "unavailable")
    assert {c.id: c.state for c in env.ground_truth().containers}[box.id] == "unavailable"


def test_noisy_state_survives_save_and_restore() -> None:
    env = HouseEnv(split="standard", render_rgbd=False)
    env.reset(seed=9)
    _wander(env, 20, seed=1)
    saved = env.get_state()
    later = [i["detections"] for _, i, _ in _wander(env, 20, seed=2)]
    other = HouseEnv(split="standard", render_rgbd=False)
    other.reset(seed=9)
    other.set_state(saved)
    again = [i["detections"] for _, i, _ in _wander(other, 20, seed=2)]
    assert later == again
    assert other.state_hash() == env.state_hash()
