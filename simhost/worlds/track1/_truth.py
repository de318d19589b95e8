"""The organizer-only ground truth of a house, shaped like ``world_model.json``.

``HouseTruth`` has the agent's ``WorldModel`` sections under the same names (``rooms``,
``connections``, ``doors``, ``containers``, ``objects``, ``affordances``), each entry a
superset of the agent's entry, plus what only the organizer knows (furniture, access poses,
tools that were taken away, the robot). Scorers compare the two section by section. Never
sent to the agent.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class _Truth(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class RoomTruth(_Truth):
    id: int
    type: str
    bounds: tuple[float, float, float, float]
    """x0, y0, x1, y1 (metres, to the wall centre lines)."""
    centre: tuple[float, float]
    cells: tuple[tuple[int, int], ...]


class ConnectionTruth(_Truth):
    rooms: tuple[int, int]
    """The two rooms, lower id first."""
    door: int


class DoorTruth(_Truth):
    id: int
    rooms: tuple[int, int]
    state: str
    """``open``, ``closed`` or ``locked``."""
    position: tuple[float, float]
    """The doorway's centre."""


class FurnitureTruth(_Truth):
    """A piece of furniture, or a container (then ``contents`` lists what is inside)."""

    id: int
    kind: str
    category: str
    room: int
    position: tuple[float, float]
    yaw: float
    size: tuple[float, float, float]
    state: str
    """Containers: ``open``, ``closed`` or ``unavailable``; surfaces: ``dirty``, ``clean``,
    ``none``."""
    access: tuple[float, float, float]
    """A collision-free robot pose (x, y, yaw) in front of it, facing it."""
    contents: tuple[int, ...] = ()


class ObjectTruth(_Truth):
    """An object or a tool that is still in the house."""

    id: int
    kind: str
    category: str
    colour: str
    room: int
    receptacle: int
    """The furniture or container it rests on or in; -1 while held."""
    slot: int
    position: tuple[float, float, float]
    state: str
    held: bool
    affordances: tuple[str, ...]


class ToolTruth(_Truth):
    id: int
    category: str
    colour: str
    affordances: tuple[str, ...]
    available: bool
    """False once the tool was taken away (tool substitution)."""


class AffordanceTruth(_Truth):
    tool: int
    affordance: str


class RobotTruth(_Truth):
    x: float
    y: float
    yaw: float
    room: int
    held: int


class HouseTruth(_Truth):
    """Everything true about a house at one moment (JSON with ``model_dump(mode="json")``)."""

    version: int = 2
    seed: int
    layout_digest: str
    rooms: tuple[RoomTruth, ...]
    connections: tuple[ConnectionTruth, ...]
    doors: tuple[DoorTruth, ...]
    furniture: tuple[FurnitureTruth, ...]
    """Surfaces only (no containers)."""
    containers: tuple[FurnitureTruth, ...]
    objects: tuple[ObjectTruth, ...]
    """Objects and tools still in the house."""
    tools: tuple[ToolTruth, ...]
    """Every tool, available or not."""
    affordances: tuple[AffordanceTruth, ...]
    """(tool, affordance) of the available tools."""
    removed: tuple[int, ...]
    robot: RobotTruth
    start_room: int
    backup_room: int

    def room_type(self, room: int) -> str:
        """The type of a room by id."""
        return self.rooms[room].type

    def object(self, object_id: int) -> ObjectTruth | None:
        """An object or tool still in the house, by id."""
        return next((o for o in self.objects if o.id == object_id), None)

    def receptacle(self, entity_id: int) -> FurnitureTruth | None:
        """A piece of furniture or a container, by id."""
        return next((f for f in (*self.furniture, *self.containers) if f.id == entity_id), None)

    def tools_for(self, affordance: str) -> list[int]:
        """Ids of the available tools with an affordance."""
        return sorted(a.tool for a in self.affordances if a.affordance == affordance)

    def neighbours(self, room: int) -> list[int]:
        """Rooms that share a doorway with a room."""
        return sorted({b if a == room else a for a, b in (c.rooms for c in self.connections)
                       if room in (a, b)})
