"""The symbolic world state (what MuJoCo does not hold) and the ground truth."""

from __future__ import annotations

import json
from dataclasses import dataclass, field

from ._catalogue import AFFORDANCES
from ._errors import StateError
from ._layout import Furniture, HouseLayout, Item
from ._truth import (
    AffordanceTruth,
    ConnectionTruth,
    DoorTruth,
    FurnitureTruth,
    HouseTruth,
    ObjectTruth,
    RobotTruth,
    RoomTruth,
    ToolTruth,
)


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
    used_by: dict[int, int] = field(default_factory=dict)
    """target id -> the tool that last changed its condition."""
    odometry: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """The robot's pose as its odometry estimates it (drifts when odometry is noisy)."""
    sign_room: int = -1
    """The room whose sign the robot read last (``room_sign="on_entry"``)."""
    sign_step: int = 0
    """The step at which it read that sign."""
    noise_seed: int = 0
    """Keys every random draw of the sensors (with the step count)."""

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

    def visible_state(self, layout: HouseLayout, entity_id: int, *, reveal: bool = True) -> str:
        """The state a detection shows for an entity. Without ``reveal``, a locked door
        looks ``closed`` and an unavailable container looks ``open``/``closed`` as it is."""
        kind = layout.kind_of(entity_id)
        if kind == "door":
            state = self.doors[entity_id]
            return "closed" if state == "locked" and not reveal else state
        if kind == "container":
            return self.container_state(entity_id) if reveal else self.containers[entity_id]
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
            "used_by": {str(k): v for k, v in sorted(self.used_by.items())},
            "odometry": [float(v) for v in self.odometry],
            "sign_room": self.sign_room,
            "sign_step": self.sign_step,
            "noise_seed": self.noise_seed,
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
                used_by={int(k): int(v) for k, v in doc["used_by"].items()},
                odometry=(
                    float(doc["odometry"][0]),
                    float(doc["odometry"][1]),
                    float(doc["odometry"][2]),
                ),
                sign_room=int(doc["sign_room"]),
                sign_step=int(doc["sign_step"]),
                noise_seed=int(doc["noise_seed"]),
            )
        except (ValueError, KeyError, TypeError, IndexError) as exc:
            raise StateError(f"corrupt symbolic state: {exc}") from exc


def ground_truth(
    layout: HouseLayout,
    world: WorldState,
    robot: tuple[float, float, float],
    hand: tuple[float, float, float],
) -> HouseTruth:
    """The organizer-only ground truth. Never sent to the agent.

    Args:
        layout: the house.
        world: its symbolic state.
        robot: robot pose (x, y, yaw).
        hand: position of a held item.
    """

    def r(v: float, n: int = 3) -> float:
        return round(float(v), n)

    furniture, containers = [], []
    for f in layout.furniture:
        entry = FurnitureTruth(
            id=f.id,
            kind=f.kind,
            category=f.category,
            room=f.room,
            position=(r(f.pos[0]), r(f.pos[1])),
            yaw=r(f.yaw, 4),
            size=(r(f.size[0]), r(f.size[1]), r(f.size[2])),
            state=world.visible_state(layout, f.id),
            access=(r(f.access[0]), r(f.access[1]), r(f.access[2])),
            contents=tuple(world.contents(f.id)) if f.kind == "container" else (),
        )
        (containers if f.kind == "container" else furniture).append(entry)
    tools = [
        ToolTruth(
            id=i.id,
            category=i.category,
            colour=i.colour,
            affordances=i.affordances,
            available=i.id not in world.removed,
        )
        for i in layout.items
        if i.kind == "tool"
    ]
    objects = [
        _item_truth(layout, world, item, robot, hand)
        for item in layout.items
        if item.id not in world.removed
    ]
    return HouseTruth(
        seed=layout.seed,
        layout_digest=layout.digest(),
        rooms=tuple(
            RoomTruth(
                id=room.id,
                type=room.type,
                bounds=(r(room.bounds[0]), r(room.bounds[1]), r(room.bounds[2]), r(room.bounds[3])),
                centre=(r(room.centre[0]), r(room.centre[1])),
                cells=room.cells,
            )
            for room in layout.rooms
        ),
        connections=tuple(ConnectionTruth(rooms=(a, b), door=d) for a, b, d in layout.edges()),
        doors=tuple(
            DoorTruth(
                id=d.id,
                rooms=d.rooms,
                state=world.doors[d.id],
                position=(r(d.centre[0]), r(d.centre[1])),
            )
            for d in layout.doors
        ),
        furniture=tuple(furniture),
        containers=tuple(containers),
        objects=tuple(objects),
        tools=tuple(tools),
        affordances=tuple(
            AffordanceTruth(tool=t.id, affordance=a)
            for a in AFFORDANCES
            for t in tools
            if a in t.affordances and t.available
        ),
        removed=tuple(sorted(world.removed)),
        robot=RobotTruth(
            x=r(robot[0], 4),
            y=r(robot[1], 4),
            yaw=r(robot[2], 4),
            room=layout.room_at(robot[0], robot[1]),
            held=world.held,
        ),
        start_room=layout.start_room,
        backup_room=layout.backup_room,
    )


def _item_truth(
    layout: HouseLayout,
    world: WorldState,
    item: Item,
    robot: tuple[float, float, float],
    hand: tuple[float, float, float],
) -> ObjectTruth:
    if item.id == world.held:
        pos, rec, slot = hand, -1, -1
        room = layout.room_at(robot[0], robot[1])
    else:
        rec, slot = world.places[item.id]
        pos = layout.item_position(item, rec, slot)
        receptacle = layout.entity(rec)
        assert isinstance(receptacle, Furniture)
        room = receptacle.room
    return ObjectTruth(
        id=item.id,
        kind=item.kind,
        category=item.category,
        colour=item.colour,
        room=room,
        receptacle=rec,
        slot=slot,
        position=(round(float(pos[0]), 3), round(float(pos[1]), 3), round(float(pos[2]), 3)),
        state=world.conditions.get(item.id, "none"),
        held=item.id == world.held,
        affordances=item.affordances,
    )
