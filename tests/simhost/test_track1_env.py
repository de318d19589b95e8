"""HouseEnv: spaces, check_env, primitives and their preconditions, determinism, state."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from simhost.worlds.track1 import (
    ENV_ID,
    PRIMITIVES,
    REASONS,
    ConfigError,
    Furniture,
    HouseEnv,
    HouseParams,
    Item,
    StateError,
    TaskError,
    generate_house,
    make_action,
)

SEED = 3


def _step(env: HouseEnv, primitive: str, **kw: Any) -> tuple[dict, float, bool, dict]:
    obs, reward, terminated, _truncated, info = env.step(make_action(primitive, **kw))
    return obs, reward, terminated, info


def _result(env: HouseEnv, primitive: str, **kw: Any) -> dict:
    return _step(env, primitive, **kw)[3]["action_result"]


def _world(env: HouseEnv) -> str:
    assert env.house is not None
    doc = json.loads(env.house.world.to_json())
    doc.pop("steps")
    return json.dumps(doc, sort_keys=True)


def _fails_unchanged(env: HouseEnv, reason: str, primitive: str, **kw: Any) -> None:
    assert env.house is not None
    world = _world(env)
    physics = env.house.sim.get_physics()
    res = _result(env, primitive, **kw)
    assert res == {"ok": False, "reason": reason, "primitive": primitive}, res
    assert reason in REASONS
    assert _world(env) == world
    assert np.array_equal(env.house.sim.get_physics(), physics)


def _ok(env: HouseEnv, primitive: str, **kw: Any) -> dict:
    obs, _r, _t, info = _step(env, primitive, **kw)
    assert info["action_result"]["ok"], info["action_result"]
    assert obs["last_action_ok"][0] == 1
    return info


def _go(env: HouseEnv, pose: tuple[float, float, float]) -> dict:
    env.teleport_robot(*pose)
    return _step(env, "noop")[3]


def _seen(info: dict) -> dict[int, dict]:
    return {d["id"]: d for d in info["detections"]}


@pytest.fixture
def env() -> HouseEnv:
    e = HouseEnv()
    e.reset(seed=SEED)
    return e


def test_spaces_and_check_env() -> None:
    env = HouseEnv()
    assert list(env.action_space.spaces) == ["primitive", "move", "target", "tool"]
    assert PRIMITIVES == ("noop", "move", "open", "close", "pick", "place", "use", "done")
    keys = set(env.observation_space.spaces)
    assert {
        "odometry",
        "range_scan",
        "room",
        "room_type",
        "held",
        "last_action_ok",
        "det_mask",
        "det_id",
        "det_category",
        "det_colour",
        "det_rel_pos",
        "det_state",
    } <= keys
    assert env.observation_space["range_scan"].shape == (36,)
    check_env(env, skip_render_check=True)
    made = gym.make(ENV_ID, render_mode="rgb_array")
    check_env(made.unwrapped)
    frame = made.unwrapped.render()
    assert frame is not None and frame.ndim == 3
    made.close()


def test_reset_seed_selects_the_house() -> None:
    env = HouseEnv()
    obs1, info1 = env.reset(seed=1)
    digest1 = env.layout.digest()
    env.reset(seed=2)
    assert env.layout.digest() != digest1
    obs3, info3 = env.reset(seed=1)
    assert env.layout.digest() == digest1 == generate_house(1).digest()
    assert all(np.array_equal(obs1[k], obs3[k]) for k in obs1)
    assert info1 == info3
    assert info1["room"] == {
        "id": env.layout.start_room,
        "type": env.layout.rooms[env.layout.start_room].type,
    }
    fixed = HouseEnv(generate_house(5))
    fixed.reset(seed=99)
    assert fixed.layout.seed == 5


def test_unknown_option_suggests_the_right_name() -> None:
    with pytest.raises(ConfigError, match="did you mean 'scan_rays'"):
        HouseEnv(scan_ray=10)
    with pytest.raises(gym.error.ResetNeeded):
        HouseEnv().step(make_action("noop"))


def test_move_forward_and_turn(env: HouseEnv) -> None:
    x, y, yaw = env.layout.start
    env.teleport_robot(x, y, 0.0)
    obs, _r, _t, info = _step(env, "move", turn=1.0)
    assert math.isclose(float(obs["odometry"][2]), math.pi / 4, abs_tol=0.01)
    obs, _r, _t, info = _step(env, "move", forward=0.6)
    assert not info["collided"]
    dx, dy = obs["odometry"][0] - x, obs["odometry"][1] - y
    assert math.isclose(math.hypot(dx, dy), 0.3, abs_tol=0.01)
    assert math.isclose(math.atan2(dy, dx), math.pi / 4, abs_tol=0.02)


def test_move_stops_on_collision(env: HouseEnv) -> None:
    room = env.layout.rooms[env.layout.start_room]
    x, y, _ = env.layout.start
    env.teleport_robot(x, y, -math.pi / 2)  # face the south wall
    collided = False
    for _ in range(40):
        obs, _r, _t, info = _step(env, "move", forward=1.0)
        if info["collided"]:
            collided = True
            break
    assert collided and info["action_result"] == {
        "ok": True,
        "reason": "collided",
        "primitive": "move",
    }
    assert obs["collided"][0] == 1
    assert float(obs["range_scan"].min()) > 0.25  # stopped short of the obstacle, not inside it
    assert env.house is not None and not env.house.sim.robot_in_contact()
    before = obs["odometry"].copy()
    obs, _r, _t, info = _step(env, "move", forward=1.0)
    assert info["collided"] and np.allclose(obs["odometry"], before, atol=0.02)
    assert obs["room"][0] == env.layout.room_at(float(before[0]), float(before[1]))
    assert room.bounds[1] < before[1]


def test_bad_actions_never_reach_mujoco(env: HouseEnv) -> None:
    assert env.house is not None
    for bad in (float("nan"), float("inf"), -float("inf")):
        _fails_unchanged(env, "non_finite_action", "move", forward=bad)
    obs, _r, _t, _tr, info = env.step({"primitive": 99})
    assert info["action_result"]["reason"] == "invalid_action" and obs["last_action_ok"][0] == 0
    for bad_action in (
        "move",
        None,
        {"primitive": 1, "move": [1.0]},
        {"primitive": 4, "target": 999},
        {"primitive": 1.5},
    ):
        info = env.step(bad_action)[4]
        assert info["action_result"]["reason"] == "invalid_action", bad_action
    assert np.all(np.isfinite(env.house.sim.data.ctrl))
    info = env.step({"primitive": "move", "move": np.array([9.0, 0.0])})[4]  # clipped, runs
    assert info["action_result"]["ok"]
    assert set(info["sim_warnings"]) >= {"badqacc", "badctrl"} and not any(
        info["sim_warnings"].values()
    )
    assert env.house.sim.model.opt.disableflags & (1 << 16)  # autoreset disabled


def test_door_preconditions(env: HouseEnv) -> None:
    door = env.layout.doors[0]
    other = next(r for r in door.rooms if r != door.swing_room)
    info = _go(env, door.approach(other, 0.8))
    assert door.id in _seen(info)
    if _seen(info)[door.id]["state"] == "open":
        _ok(env, "close", target=door.id)
    _fails_unchanged(env, "already_closed", "close", target=door.id)
    info = _ok(env, "open", target=door.id)
    assert _seen(info)[door.id]["state"] == "open"
    _fails_unchanged(env, "already_open", "open", target=door.id)
    _ok(env, "close", target=door.id)
    # In the swing room, right behind the door: the door would hit the robot.
    _go(env, door.approach(door.swing_room, 0.6))
    _fails_unchanged(env, "blocked_by_robot", "open", target=door.id)
    _go(env, door.approach(door.swing_room, 2.0))
    _fails_unchanged(env, "out_of_reach", "open", target=door.id)
    _go(env, door.approach(other, 0.8))
    env.lock_door(door.id)
    info = _step(env, "noop")[3]
    assert _seen(info)[door.id]["state"] == "locked"
    _fails_unchanged(env, "locked", "open", target=door.id)
    _fails_unchanged(env, "unknown_id", "open", target=250)
    hidden = _invisible_entity(env, info)
    _fails_unchanged(env, "not_visible", "open", target=hidden)


def _invisible_entity(env: HouseEnv, info: dict) -> int:
    seen = _seen(info)
    return next(f.id for f in env.layout.furniture if f.id not in seen)


def _container(env: HouseEnv, *, with_items: bool) -> Furniture | None:
    for f in env.layout.furniture:
        if f.kind == "container" and f.opening == "front":
            has = any(i.receptacle == f.id for i in env.layout.items)
            if has == with_items:
                return f
    return None


def test_container_preconditions() -> None:
    env = HouseEnv()
    for seed in range(SEED, SEED + 30):
        env.reset(seed=seed)
        box = _container(env, with_items=True)
        if box is not None:
            break
    assert box is not None, "no house with a filled front-opening container"
    info = _go(env, box.access)
    if _seen(info)[box.id]["state"] == "open":
        _ok(env, "close", target=box.id)
    inside = [i.id for i in env.layout.items if i.receptacle == box.id]
    info = _step(env, "noop")[3]
    assert not set(inside) & set(_seen(info)), "closed containers hide their contents"
    _fails_unchanged(env, "already_closed", "close", target=box.id)
    info = _ok(env, "open", target=box.id)
    assert set(inside) <= set(_seen(info)), "open containers show their contents"
    assert all(_seen(info)[i]["rel_pos"][0] > 0 for i in inside)
    _fails_unchanged(env, "already_open", "open", target=box.id)
    _ok(env, "pick", target=inside[0])
    _ok(env, "close", target=box.id)
    _fails_unchanged(env, "container_closed", "place", target=box.id)
    _ok(env, "open", target=box.id)
    _ok(env, "place", target=box.id)
    env.make_container_unavailable(box.id)
    info = _step(env, "noop")[3]
    assert _seen(info)[box.id]["state"] == "unavailable"
    _fails_unchanged(env, "unavailable", "open", target=box.id)
    table = next(f for f in env.layout.furniture if f.kind == "furniture")
    _go(env, table.access)
    _fails_unchanged(env, "not_openable", "open", target=table.id)


def _surface_item(env: HouseEnv, kind: str = "object") -> tuple[Item, Furniture]:
    for item in env.layout.items:
        rec = env.layout.entity(item.receptacle)
        if item.kind == kind and isinstance(rec, Furniture) and rec.kind == "furniture":
            return item, rec
    raise AssertionError


def test_pick_and_place_preconditions(env: HouseEnv) -> None:
    item, rec = _surface_item(env)
    info = _go(env, rec.access)
    assert item.id in _seen(info)
    _fails_unchanged(env, "hand_empty", "place", target=rec.id)
    _fails_unchanged(env, "not_pickable", "pick", target=rec.id)
    obs, _r, _t, info = _step(env, "pick", target=item.id)
    assert info["action_result"]["ok"] and obs["held"][0] == item.id and info["held"] == item.id
    assert item.id not in _seen(info)
    _fails_unchanged(env, "hand_full", "pick", target=item.id)
    door = env.layout.doors[0]
    _go(env, door.approach(next(r for r in door.rooms if r != door.swing_room)))
    _fails_unchanged(env, "not_a_receptacle", "place", target=door.id)
    truth = env.ground_truth().object(item.id)
    robot = env.ground_truth().robot
    assert truth is not None and truth.held
    assert math.dist(truth.position[:2], (robot.x, robot.y)) < 0.5
    _go(env, rec.access)
    info = _ok(env, "place", target=rec.id)
    assert item.id in _seen(info) and info["held"] == -1


def test_receptacle_full() -> None:
    env = HouseEnv()
    for seed in range(40):
        env.reset(seed=seed)
        bins = [f for f in env.layout.furniture if f.category == "bin"]
        if bins:
            break
    else:
        raise AssertionError("no seed below 40 with a bin")
    b = bins[0]
    assert env.house is not None
    for item in [i for i in env.layout.items if i.kind == "object" and i.receptacle != b.id]:
        _fetch(env, item)
        info = _go(env, b.access)
        if _seen(info)[b.id]["state"] == "closed":
            _ok(env, "open", target=b.id)
        if env.house.world.free_slot(env.layout, b.id) is None:
            break
        _ok(env, "place", target=b.id)
    _fails_unchanged(env, "receptacle_full", "place", target=b.id)


def test_use_preconditions(env: HouseEnv) -> None:
    dirty = next(f for f in env.layout.furniture if f.initial_state == "dirty")
    wiper = next(i for i in env.layout.items if "wipe" in i.affordances)
    cutter = next(i for i in env.layout.items if "cut" in i.affordances)
    plain = next(i for i in env.layout.items if i.kind == "object")
    _go(env, dirty.access)
    _fails_unchanged(env, "tool_not_held", "use", tool=wiper.id, target=dirty.id)
    for holding, reason in ((plain, "not_a_tool"), (cutter, "lacks_affordance"), (wiper, None)):
        _fetch(env, holding)
        _go(env, dirty.access)
        if reason is not None:
            _fails_unchanged(env, reason, "use", tool=holding.id, target=dirty.id)
            _put_down(env)
    info = _ok(env, "use", tool=wiper.id, target=dirty.id)
    assert _seen(info)[dirty.id]["state"] == "clean"
    _fails_unchanged(env, "no_effect", "use", tool=wiper.id, target=dirty.id)
    door = min(env.layout.doors, key=lambda d: math.dist(d.centre, dirty.access[:2]))
    _go(env, door.approach(next(r for r in door.rooms if r != door.swing_room)))
    _fails_unchanged(env, "not_applicable", "use", tool=wiper.id, target=door.id)


def _fetch(env: HouseEnv, item: Item) -> None:
    assert env.house is not None
    rec_id, _slot = env.house.world.places[item.id]
    rec = env.layout.entity(rec_id)
    assert isinstance(rec, Furniture)
    info = _go(env, rec.access)
    if rec.kind == "container" and _seen(info)[rec.id]["state"] == "closed":
        _ok(env, "open", target=rec.id)
    _ok(env, "pick", target=item.id)


def _put_down(env: HouseEnv) -> None:
    assert env.house is not None
    for f in env.layout.furniture:
        if f.kind == "furniture" and env.house.world.free_slot(env.layout, f.id) is not None:
            _go(env, f.access)
            _ok(env, "place", target=f.id)
            return
    raise AssertionError


def _script(env: HouseEnv, n: int) -> list[str]:
    env.action_space.seed(7)
    hashes = []
    for k in range(n):
        action = env.action_space.sample()
        if k % 3 == 0:
            action["primitive"] = 1
        env.step(action)
        hashes.append(env.state_hash())
    return hashes


def test_same_seed_same_actions_same_state_hash() -> None:
    a, b = HouseEnv(), HouseEnv()
    a.reset(seed=21)
    b.reset(seed=21)
    assert a.state_hash() == b.state_hash()
    assert _script(a, 30) == _script(b, 30)
    c = HouseEnv()
    c.reset(seed=22)
    assert c.state_hash() != a.state_hash()


def test_get_set_state_replays_bit_for_bit(env: HouseEnv) -> None:
    item, rec = _surface_item(env)
    _go(env, rec.access)
    _ok(env, "pick", target=item.id)
    saved, saved_hash = env.get_state(), env.state_hash()
    moves = [make_action("move", forward=0.7, turn=0.3 * k) for k in range(-3, 4)]
    first = []
    for m in moves:
        env.step(m)
        first.append(env.state_hash())
    other = HouseEnv(generate_house(SEED))
    other.reset()
    other.set_state(saved)
    assert other.state_hash() == saved_hash
    second = []
    for m in moves:
        other.step(m)
        second.append(other.state_hash())
    assert first == second
    with pytest.raises(StateError, match="another house"):
        HouseEnv(generate_house(SEED + 1)).set_state(saved)
    with pytest.raises(StateError):
        env.set_state(saved[:-5])
    with pytest.raises(StateError):
        env.set_state(b"garbage")


def test_task_reward_and_done() -> None:
    env = HouseEnv()
    env.reset(seed=SEED)
    item, rec = _surface_item(env)
    goal = next(f for f in env.layout.furniture if f.kind == "furniture" and f.id != rec.id)
    task = {"kind": "place", "object": item.id, "receptacles": [goal.id]}
    env.reset(seed=SEED, options={"task": task})
    _go(env, rec.access)
    obs, reward, _t, info = _step(env, "pick", target=item.id)
    assert reward == 0.0 and info["task_satisfied"] is False
    _r = _step(env, "place", target=250)[1]
    assert _r == pytest.approx(-0.01)
    _go(env, goal.access)
    obs, reward, _t, info = _step(env, "place", target=goal.id)
    assert reward == 1.0 and info["task_satisfied"]
    assert _step(env, "noop")[1] == 0.0
    obs, reward, terminated, info = _step(env, "done")
    assert terminated and info["action_result"]["ok"]
    with pytest.raises(TaskError):
        env.reset(seed=SEED, options={"task": {"kind": "place", "object": 9999}})
    with pytest.raises(ValueError, match="unknown reset options"):
        env.reset(seed=SEED, options={"tsk": {}})


def test_observation_matches_info(env: HouseEnv) -> None:
    obs, _r, _t, info = _step(env, "noop")
    n = int(obs["det_mask"].sum())
    assert n == min(len(info["detections"]), env.config.max_detections)
    assert obs["det_id"][:n].tolist() == [d["id"] for d in info["detections"]][:n]
    assert (obs["det_id"][n:] == -1).all()
    gt = env.ground_truth()
    assert math.isclose(obs["odometry"][0], gt.robot.x, abs_tol=1e-3)
    assert obs["room"][0] == gt.robot.room == info["room"]["id"]


def test_import_is_light_and_registers() -> None:
    code = (
        "import sys, simhost.worlds.track1, gymnasium as gym\n"
        "assert 'mujoco' not in sys.modules, 'mujoco imported eagerly'\n"
        "ids = {'eagc/HouseDev-v0', 'eagc/House-v0', 'eagc/HouseChallenge-v0'}\n"
        "assert ids <= set(gym.registry)\n"
        "from simhost.worlds.track1 import HouseEnv\n"
        "assert 'mujoco' in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, cwd=_repo_root())


def _repo_root() -> str:
    import pathlib

    return str(pathlib.Path(__file__).resolve().parents[2])


def test_challenge_env_builds_large_houses() -> None:
    env = gym.make("eagc/HouseChallenge-v0")
    env.reset(seed=4)
    assert len(env.unwrapped.layout.rooms) >= 6
    assert env.unwrapped.params == HouseParams.challenge()
    env.close()


def _pick_everything(env: HouseEnv) -> None:
    """From each receptacle's access pose (collision-free), every item on or in it can be
    seen and picked (containers opened first)."""
    assert env.house is not None
    for rec in env.layout.furniture:
        items = [i for i in env.layout.items if i.receptacle == rec.id]
        if not items:
            continue
        info = _go(env, rec.access)  # teleport_robot raises if the pose collides
        assert rec.id in _seen(info), (env.layout.seed, rec.id)
        opened = rec.kind == "container" and _seen(info)[rec.id]["state"] == "closed"
        if opened:
            info = _ok(env, "open", target=rec.id)
        for item in items:
            assert item.id in _seen(info), (env.layout.seed, rec.category, item.category)
            _ok(env, "pick", target=item.id)
            info = _ok(env, "place", target=rec.id)
        if opened:  # an open lid may hide a neighbour's opening: leave it as it was
            _ok(env, "close", target=rec.id)


@pytest.mark.parametrize("seed", range(8))
def test_every_item_can_be_picked_from_its_access_pose(seed: int) -> None:
    env = HouseEnv(params=HouseParams.challenge() if seed % 2 else HouseParams())
    env.reset(seed=seed)
    _pick_everything(env)


@pytest.mark.slow
def test_items_and_doors_usable_many_seeds() -> None:
    for seed in range(8, 60):
        env = HouseEnv(params=HouseParams.challenge() if seed % 2 else HouseParams())
        env.reset(seed=seed)
        _pick_everything(env)
        _operate_doors(env)
        env.close()


def _operate_doors(env: HouseEnv) -> None:
    for door in env.layout.doors:
        for room in door.rooms:
            info = _go(env, door.approach(room, 1.35 if room == door.swing_room else 0.8))
            assert door.id in _seen(info), (env.layout.seed, door.id, room)
            state = _seen(info)[door.id]["state"]
            first, second = ("close", "open") if state == "open" else ("open", "close")
            _ok(env, first, target=door.id)
            _ok(env, second, target=door.id)


@pytest.mark.parametrize("seed", range(6))
def test_every_door_operable_from_both_sides(seed: int) -> None:
    """From each side of each doorway there is a collision-free pose (``Door.approach``:
    0.8 m on the far side, 1.35 m on the swing side) from which the door opens and closes."""
    env = HouseEnv(params=HouseParams.challenge() if seed % 2 else HouseParams())
    env.reset(seed=seed)
    _operate_doors(env)
