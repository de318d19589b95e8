"""The symbolic world state (what MuJoCo does not hold) and the ground-truth dictionary."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

from ._catalogue import AFFORDANCES
from ._errors import StateError
from ._layout import Door, Furniture, HouseLayout, Item


@dataclass
class WorldState:
    """Door, container, placement and condition states; the authority the physics follows."""

    doors: dict[int, str]
    """door id -> ``open`` / ``closed`` / ``locked``."""
    containers: dict[int, str]
    """container id -> ``open`` / ``closed``."""
    places: dict[int, tuple[int, int]]
    """item id -> (receptacle id, slot); absent while held or after removal."""
    conditions: dict[int, str]
    """furniture or item id -> ``none`` / ``dirty`` / ``clean`` / ``whole`` / ... ."""
    unavailable: set[int] = field(default_factory=set)
    removed: set[int] = field(default_factory=set)
    held: int = -1
    steps: int = 0
    task_done: bool = False

    @classmethod
    def initial(cls, layout: HouseLayout) -> WorldState:
        """The state a layout starts in."""
        return cls(
            doors={d.id: d.initial_state for d in layout.doors},
            containers={f.id: f.initial_state for f in layout.furniture if f.kind == "container"},
            places={i.id: (i.receptacle, i.slot) for i in layout.items},
            conditions={
                e.id: e.initial_state
                for e in (*layout.furniture, *layout.items)
                if e.kind != "container"
            },
        )

    def container_state(self, container_id: int) -> str:
        """``unavailable``, else ``open`` / ``closed``."""
        if container_id in self.unavailable:
            return "unavailable"
        return self.containers[container_id]

    def visible_state(self, layout: HouseLayout, entity_id: int) -> str:
        """The state a detection shows for an entity."""
        kind = layout.kind_of(entity_id)
        if kind == "door":
            return self.doors[entity_id]
        if kind == "container":
            return self.container_state(entity_id)
        return self.conditions.get(entity_id, "none")

    def free_slot(self, layout: HouseLayout, receptacle_id: int) -> int | None:
        """The lowest free slot of a receptacle, or None when it is full."""
        rec = layout.entity(receptacle_id)
        assert isinstance(rec, Furniture)
        taken = {slot for r, slot in self.places.values() if r == receptacle_id}
        return next((s for s in range(rec.slots) if s not in taken), None)

    def contents(self, receptacle_id: int) -> list[int]:
        """Items resting on or in a receptacle, by id."""
        return sorted(i for i, (r, _s) in self.places.items() if r == receptacle_id)

    def to_json(self) -> bytes:
        """Canonical JSON (sorted keys, sorted sets)."""
        doc = {
            "doors": {str(k): v for k, v in sorted(self.doors.items())},
            "containers": {str(k): v for k, v in sorted(self.containers.items())},
            "places": {str(k): list(v) for k, v in sorted(self.places.items())},
            "conditions": {str(k): v for k, v in sorted(self.conditions.items())},
            "unavailable": sorted(self.unavailable),
            "removed": sorted(self.removed),
            "held": self.held,
            "steps": self.steps,
            "task_done": self.task_done,
        }
        return json.dumps(doc, sort_keys=True, separators=(",", ":")).encode()

    @classmethod
    def from_json(cls, raw: bytes) -> WorldState:
        """Inverse of :meth:`to_json`."""
        try:
            doc = json.loads(raw)
            return cls(
                doors={int(k): v for k, v in doc["doors"].items()},
                containers={int(k): v for k, v in doc["containers"].items()},
                places={int(k): (int(v[0]), int(v[1])) for k, v in doc["places"].items()},
                conditions={int(k): v for k, v in doc["conditions"].items()},
                unavailable=set(doc["unavailable"]),
                removed=set(doc["removed"]),
                held=int(doc["held"]),
                steps=int(doc["steps"]),
                task_done=bool(doc["task_done"]),
            )
        except (ValueError, KeyError, TypeError, IndexError) as exc:
            raise StateError(f"corrupt symbolic state: {exc}") from exc


def ground_truth(
    layout: HouseLayout,
    world: WorldState,
    robot: tuple[float, float, float],
    hand: tuple[float, float, float],
) -> dict[str, Any]:
    """The organizer-only ground truth (JSON-serialisable). Never sent to the agent.

    Args:
        layout: the house.
        world: its symbolic state.
        robot: robot pose (x, y, yaw).
        hand: position of a held item.
    """

    def r3(v: tuple[float, ...]) -> list[float]:
        return [round(float(x), 3) for x in v]

    rooms = [
        {
            "id": r.id,
            "type": r.type,
            "bounds": r3(r.bounds),
            "centre": r3(r.centre),
            "cells": [list(c) for c in r.cells],
        }
        for r in layout.rooms
    ]
    doors = [_door_truth(d, world) for d in layout.doors]
    furniture, containers = [], []
    for f in layout.furniture:
        entry = {
            "id": f.id,
            "category": f.category,
            "room": f.room,
            "position": r3(f.pos),
            "yaw": round(f.yaw, 4),
            "size": r3(f.size),
            "state": world.visible_state(layout, f.id),
            "access": r3(f.access),
        }
        if f.kind == "container":
            entry["contents"] = world.contents(f.id)
            containers.append(entry)
        else:
            furniture.append(entry)
    objects, tools = [], []
    for item in layout.items:
        if item.kind == "tool":
            tools.append(
                {
                    "id": item.id,
                    "category": item.category,
                    "colour": item.colour,
                    "affordances": list(item.affordances),
                    "available": item.id not in world.removed,
                }
            )
        if item.id in world.removed:
            continue
        objects.append(_item_truth(layout, world, item, robot, hand))
    affordances = {
        a: [t["id"] for t in tools if a in t["affordances"] and t["available"]] for a in AFFORDANCES
    }
    return {
        "version": 1,
        "seed": layout.seed,
        "layout_digest": layout.digest(),
        "rooms": rooms,
        "edges": [{"rooms": [a, b], "door": d} for a, b, d in layout.edges()],
        "doors": doors,
        "furniture": furniture,
        "containers": containers,
        "objects": objects,
        "tools": tools,
        "affordances": affordances,
        "removed": sorted(world.removed),
        "robot": {
            "x": round(robot[0], 4),
            "y": round(robot[1], 4),
            "yaw": round(robot[2], 4),
            "room": layout.room_at(robot[0], robot[1]),
            "held": world.held,
        },
        "start_room": layout.start_room,
        "backup_room": layout.backup_room,
    }


def _door_truth(door: Door, world: WorldState) -> dict[str, Any]:
    return {
        "id": door.id,
        "rooms": list(door.rooms),
        "state": world.doors[door.id],
        "position": [round(v, 3) for v in door.centre],
    }


def _item_truth(
    layout: HouseLayout,
    world: WorldState,
    item: Item,
    robot: tuple[float, float, float],
    hand: tuple[float, float, float],
) -> dict[str, Any]:
    if item.id == world.held:
        pos, rec, slot = hand, -1, -1
        room = layout.room_at(robot[0], robot[1])
    else:
        rec, slot = world.places[item.id]
        pos = layout.item_position(item, rec, slot)
        receptacle = layout.entity(rec)
        assert isinstance(receptacle, Furniture)
        room = receptacle.room
    return {
        "id": item.id,
        "kind": item.kind,
        "category": item.category,
        "colour": item.colour,
        "room": room,
        "receptacle": rec,
        "slot": slot,
        "position": [round(float(v), 3) for v in pos],
        "state": world.conditions.get(item.id, "none"),
        "held": item.id == world.held,
        "affordances": list(item.affordances),
    }
