"""Tasks: what the shaped reward and the feasibility check understand."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, ValidationError

from ._catalogue import AFFORDANCE_EFFECTS, AFFORDANCES
from ._errors import TaskError
from ._graph import reachable
from ._layout import Furniture, HouseLayout, Item
from ._world import WorldState


class HouseTask(BaseModel):
    """A goal in the house, by instance ids.

    ``place``: ``object`` rests on or in any one of ``receptacles``.
    ``use``: ``target`` is in the state ``affordance`` leads to (e.g. wipe: clean), by one of
    ``tools`` when any are listed.
    ``goto``: the robot is in ``room``.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: Literal["place", "use", "goto"]
    object: int | None = None
    receptacles: tuple[int, ...] = ()
    target: int | None = None
    affordance: str | None = None
    tools: tuple[int, ...] = ()
    room: int | None = None

    @classmethod
    def parse(cls, raw: HouseTask | dict[str, Any], layout: HouseLayout) -> HouseTask:
        """Validate a task against a layout; raises TaskError naming the bad field."""
        try:
            task = raw if isinstance(raw, HouseTask) else cls.model_validate(raw)
        except ValidationError as exc:
            raise TaskError(f"bad task {raw!r}: {exc.errors()[0]['msg']}") from exc
        if task.kind == "place":
            if task.object is None or layout.kind_of(task.object) not in ("object", "tool"):
                raise TaskError(
                    f"place task needs 'object', an object or tool id; got {task.object}"
                )
            if not task.receptacles or any(
                layout.kind_of(r) not in ("furniture", "container") for r in task.receptacles
            ):
                raise TaskError(f"place task needs 'receptacles' ids; got {task.receptacles}")
        elif task.kind == "use":
            if task.affordance not in AFFORDANCES:
                raise TaskError(
                    f"use task needs 'affordance' in {AFFORDANCES}; got {task.affordance}"
                )
            if task.target is None or layout.entity(task.target) is None:
                raise TaskError(f"use task needs 'target', an entity id; got {task.target}")
        elif task.room is None or not 0 <= task.room < len(layout.rooms):
            raise TaskError(f"goto task needs 'room' in [0, {len(layout.rooms)}); got {task.room}")
        return task


def task_satisfied(
    task: HouseTask, layout: HouseLayout, world: WorldState, robot_room: int
) -> bool:
    """True when the task's goal holds now."""
    if task.kind == "place":
        assert task.object is not None
        place = world.places.get(task.object)
        return place is not None and place[0] in task.receptacles
    if task.kind == "use":
        assert task.target is not None and task.affordance is not None
        if world.conditions.get(task.target) != AFFORDANCE_EFFECTS[task.affordance][1]:
            return False
        return not task.tools or world.used_by.get(task.target) in task.tools
    return robot_room == task.room


def _item_room(layout: HouseLayout, world: WorldState, item_id: int, robot_room: int) -> int | None:
    """Room of an item that can be fetched, or None (removed, or shut in an unusable container)."""
    if item_id in world.removed:
        return None
    if item_id == world.held:
        return robot_room
    rec = layout.entity(world.places[item_id][0])
    assert isinstance(rec, Furniture)
    if rec.id in world.unavailable:
        return None
    return rec.room


def task_blockers(
    task: HouseTask | None,
    layout: HouseLayout,
    world: WorldState,
    robot_room: int,
    rooms: tuple[int, ...] = (),
) -> list[str]:
    """Why the task (and the listed rooms) cannot be completed from here; empty when it can.

    Movement avoids locked doors; closed doors count as passable (the robot can open them).
    """
    nodes = [r.id for r in layout.rooms]
    locked = [d for d, s in world.doors.items() if s == "locked"]
    ok_rooms = reachable(nodes, layout.edges(), robot_room, locked)
    out = [f"room {r} unreachable" for r in rooms if r not in ok_rooms]
    if task is None or task_satisfied(task, layout, world, robot_room):
        return out
    if task.kind == "goto":
        if task.room not in ok_rooms:
            out.append(f"room {task.room} unreachable")
        return out
    if task.kind == "place":
        assert task.object is not None
        room = _item_room(layout, world, task.object, robot_room)
        if room is None or room not in ok_rooms:
            out.append(f"object {task.object} cannot be fetched")
        usable = []
        for r in task.receptacles:
            rec = layout.entity(r)
            assert isinstance(rec, Furniture)
            if (
                r not in world.unavailable
                and rec.room in ok_rooms
                and world.free_slot(layout, r) is not None
            ):
                usable.append(r)
        if not usable:
            out.append("no usable receptacle")
        return out
    assert task.target is not None and task.affordance is not None
    target = layout.entity(task.target)
    before = AFFORDANCE_EFFECTS[task.affordance][0]
    if world.conditions.get(task.target) != before:
        out.append(f"target {task.target} is not {before}")
    if isinstance(target, Item):
        room = _item_room(layout, world, target.id, robot_room)
    else:
        room = target.room if isinstance(target, Furniture) else None
    if room is None or room not in ok_rooms:
        out.append(f"target {task.target} unreachable")
    tools = [i for i in layout.items if task.affordance in i.affordances
             and (not task.tools or i.id in task.tools)]
    if not any(
        (r := _item_room(layout, world, t.id, robot_room)) is not None and r in ok_rooms
        for t in tools
    ):
        out.append(f"no reachable tool that can {task.affordance}")
    return out
