"""Perturbations (the controlled exceptions), ground truth and path helpers of HouseEnv."""

from __future__ import annotations

import math
from typing import Any

import pytest

from simhost.worlds.track1 import (
    Furniture,
    HouseEnv,
    HouseParams,
    HouseTruth,
    PerturbationError,
    generate_house,
    make_action,
)


def _noop(env: HouseEnv) -> dict[str, Any]:
    return env.step(make_action("noop"))[4]


def _seen(env: HouseEnv, pose: tuple[float, float, float]) -> dict[int, dict]:
    env.teleport_robot(*pose)
    return {d["id"]: d for d in _noop(env)["detections"]}


def _far_room_path(env: HouseEnv) -> list[int]:
    start = env.layout.start_room
    paths = [env.shortest_path(start, r.id) for r in env.layout.rooms]
    return max(paths, key=len)


@pytest.mark.parametrize("seed", range(6))
def test_door_lock_on_the_route_keeps_a_recoverable_path(seed: int) -> None:
    env = HouseEnv(params=HouseParams.challenge() if seed % 2 else HouseParams())
    env.reset(seed=seed)
    route = _far_room_path(env)
    door_id = env.house.route_doors(route)[0]  # type: ignore[union-attr]
    goal = route[-1]
    assert env.has_recoverable_path({"kind": "goto", "room": goal})
    event = env.lock_door(door_id)
    assert event["kind"] == "door_lock" and event["door"] == door_id
    detour = env.shortest_path(env.layout.start_room, goal)
    assert detour and detour[-1] == goal and detour != route
    assert door_id not in env.house.route_doors(detour)  # type: ignore[union-attr]
    assert env.shortest_path(env.layout.start_room, goal, avoid_locked=False) == route
    assert env.has_recoverable_path(
        {"kind": "goto", "room": goal}, rooms=tuple(range(len(env.layout.rooms)))
    )
    truth = env.ground_truth()
    assert {d.id: d.state for d in truth.doors}[door_id] == "locked"
    door = env.layout.entity(door_id)
    near = next(r for r in door.rooms if r != door.swing_room)  # type: ignore[union-attr]
    seen = _seen(env, door.approach(near))  # type: ignore[union-attr]
    assert seen[door_id]["state"] == "locked"
    info = env.step(make_action("open", target=door_id))[4]
    assert info["action_result"]["reason"] == "locked"
    with pytest.raises(PerturbationError, match="already locked"):
        env.lock_door(door_id)


def test_door_lock_refuses_while_the_robot_is_in_the_doorway() -> None:
    env = HouseEnv()
    env.reset(seed=2)
    door = env.layout.doors[0]
    env.teleport_robot(*door.centre, door.yaw + math.pi / 2)
    with pytest.raises(PerturbationError, match="stands in doorway"):
        env.lock_door(door.id)
    with pytest.raises(PerturbationError, match="not a door"):
        env.lock_door(env.layout.furniture[0].id)


def test_relocation_to_the_backup_area_is_observable() -> None:
    env = HouseEnv()
    env.reset(seed=4)
    layout = env.layout
    item = next(
        i
        for i in layout.items
        if i.kind == "object"
        and layout.entity(i.receptacle).kind == "furniture"  # type: ignore[union-attr]
        and layout.entity(i.receptacle).room != layout.backup_room  # type: ignore[union-attr]
    )
    old = layout.entity(item.receptacle)
    assert isinstance(old, Furniture)
    assert item.id in _seen(env, old.access)
    event = env.relocate_object(item.id)
    assert event["room"] == layout.backup_room
    new = layout.entity(event["receptacle"])
    assert isinstance(new, Furniture) and new.room == layout.backup_room
    assert item.id not in _seen(env, old.access)
    assert item.id in _seen(env, new.access)
    truth = env.ground_truth().object(item.id)
    assert truth is not None and truth.room == layout.backup_room and truth.receptacle == new.id
    info = env.step(make_action("pick", target=item.id))[4]
    assert info["action_result"]["ok"]
    with pytest.raises(PerturbationError, match="held"):
        env.relocate_object(item.id)


def test_unavailable_container_and_functional_substitute() -> None:
    env = HouseEnv()
    env.reset(seed=6)
    layout = env.layout
    boxes = [f for f in layout.furniture if f.kind == "container" and f.opening == "front"]
    assert len(boxes) >= 2
    target, spare = boxes[0], boxes[1]
    item = next(
        i for i in layout.items if i.kind == "object" and i.receptacle not in (target.id, spare.id)
    )
    task = {"kind": "place", "object": item.id, "receptacles": [target.id]}
    assert env.has_recoverable_path(task)
    event = env.make_container_unavailable(target.id)
    assert event["container"] == target.id
    assert not env.has_recoverable_path(task)
    assert env.has_recoverable_path({**task, "receptacles": [target.id, spare.id]})
    seen = _seen(env, target.access)
    assert seen[target.id]["state"] == "unavailable"
    for primitive in ("open", "close"):
        info = env.step(make_action(primitive, target=target.id))[4]
        assert info["action_result"]["reason"] == "unavailable"
    truth = {c.id: c for c in env.ground_truth().containers}
    assert truth[target.id].state == "unavailable"
    with pytest.raises(PerturbationError, match="already unavailable"):
        env.make_container_unavailable(target.id)


def test_tool_removal_leaves_a_substitute() -> None:
    env = HouseEnv()
    env.reset(seed=8)
    layout = env.layout
    dirty = next(f for f in layout.furniture if f.initial_state == "dirty")
    task = {"kind": "use", "affordance": "wipe", "target": dirty.id}
    wipers = [i for i in layout.items if "wipe" in i.affordances]
    first = wipers[0]
    rec = layout.entity(first.receptacle)
    assert isinstance(rec, Furniture)
    if rec.kind == "container" and _seen(env, rec.access)[rec.id]["state"] == "closed":
        assert env.step(make_action("open", target=rec.id))[4]["action_result"]["ok"]
    assert first.id in _seen(env, rec.access)
    event = env.remove_tool(first.id)
    assert event == {"kind": "tool_removal", "tool": first.id, "previous_receptacle": rec.id}
    assert first.id not in _seen(env, rec.access)
    truth = env.ground_truth()
    assert first.id not in {o.id for o in truth.objects}
    assert {t.id: t.available for t in truth.tools}[first.id] is False
    assert first.id not in truth.tools_for("wipe")
    assert env.has_recoverable_path(task), "a substitute tool can still wipe"
    for other in wipers[1:]:
        env.remove_tool(other.id)
    assert not env.has_recoverable_path(task)
    with pytest.raises(PerturbationError):
        env.remove_tool(first.id)
    with pytest.raises(PerturbationError, match="not a tool"):
        env.remove_tool(next(i.id for i in layout.items if i.kind == "object"))


def test_ground_truth_shape_and_json() -> None:
    env = HouseEnv()
    env.reset(seed=9)
    truth = env.ground_truth()
    assert HouseTruth.model_validate_json(truth.model_dump_json()) == truth
    model_sections = {"rooms", "connections", "doors", "containers", "objects", "affordances"}
    assert model_sections <= set(HouseTruth.model_fields), "shaped like world_model.json"
    layout = env.layout
    assert [r.id for r in truth.rooms] == [r.id for r in layout.rooms]
    assert {c.rooms + (c.door,) for c in truth.connections} == set(layout.edges())
    assert {d.state for d in truth.doors} <= {"open", "closed", "locked"}
    assert {c.state for c in truth.containers} <= {"open", "closed", "unavailable"}
    assert len(truth.objects) == len(layout.items)
    for obj in truth.objects:
        assert layout.room_at(*obj.position[:2]) == obj.room
    for tool in truth.tools:
        assert tool.affordances and tool.available
    assert {(a.tool, a.affordance) for a in truth.affordances} == {
        (t.id, a) for t in truth.tools for a in t.affordances}
    assert truth.robot.room == layout.start_room and truth.robot.held == -1
    assert math.isclose(truth.robot.x, layout.start[0], abs_tol=1e-3)


def test_relocation_into_a_chosen_receptacle() -> None:
    env = HouseEnv()
    env.reset(seed=4)
    layout = env.layout
    item = next(i for i in layout.items if i.kind == "object")
    home = layout.entity(item.receptacle)
    assert isinstance(home, Furniture)
    dest = next(f for f in layout.furniture if f.kind == "container" and f.room != home.room)
    event = env.relocate_object(item.id, receptacle=dest.id)
    assert event["receptacle"] == dest.id and event["room"] == dest.room
    truth = env.ground_truth().object(item.id)
    assert truth is not None and truth.receptacle == dest.id
    with pytest.raises(PerturbationError, match="item.s own"):
        env.relocate_object(item.id, receptacle=dest.id)
    other = next(f for f in layout.furniture if f.kind == "container"
                 and f.id != dest.id and env.ground_truth().receptacle(f.id).state == "open")
    event = env.relocate_object(item.id, receptacle=other.id, shut=True)
    assert event["shut"] and env.ground_truth().receptacle(other.id).state == "closed"
    env.teleport_robot(*other.access)
    seen = set(env.observe()[0]["det_id"].tolist())
    assert other.id in seen and item.id not in seen, "shut away, out of sight"


def test_perturbations_change_the_state_hash_and_survive_replay() -> None:
    env = HouseEnv(generate_house(12))
    env.reset()
    before = env.state_hash()
    container = next(f for f in env.layout.furniture if f.kind == "container")
    env.make_container_unavailable(container.id)
    assert env.state_hash() != before
    saved = env.get_state()
    other = HouseEnv(generate_house(12))
    other.reset()
    other.set_state(saved)
    assert other.state_hash() == env.state_hash()
    assert other.ground_truth() == env.ground_truth()
