"""The house description: generator parameters and the generated layout (pure data).

Coordinates are metres in the house frame: x to the east, y to the north, z up, the house's
south-west corner at the origin. Yaw is counter-clockwise from +x, in radians.
"""

from __future__ import annotations

import bisect
import hashlib
import json
import math
from functools import cached_property
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from ._catalogue import (
    AFFORDANCES,
    COLOURS,
    CONTAINER_CATEGORIES,
    DEFAULT_FURNITURE,
    DEFAULT_ITEMS,
    DEFAULT_OPTIONAL_ROOMS,
    DEFAULT_ROOM_FURNITURE,
    FURNITURE_CATEGORIES,
    MAX_ROOMS,
    OBJECT_CATEGORIES,
    REQUIRED_ROOMS,
    ROOM_TYPES,
    SEMANTIC_ROOM_ITEMS,
    STATES,
    TOOL_CATEGORIES,
    FurnitureSpec,
    ItemSpec,
    RoomFurniture,
)

WALL_THICKNESS = 0.1
WALL_HEIGHT = 2.2
DOOR_HEIGHT = 2.0
SLOT_PITCH = 0.3
SURFACE_BAND = 0.7
"""Surface slots lie within this depth of a surface's front edge (so they are in reach)."""
CARCASS = 0.03
"""Panel thickness of a container's carcass."""


def _frozen() -> ConfigDict:
    return ConfigDict(frozen=True, extra="forbid")


class HouseParams(BaseModel):
    """Parameters of :func:`generate_house`; an organizer parameter pack is one of these."""

    model_config = _frozen()

    rooms: tuple[int, int] = (3, 5)
    """Inclusive range of the number of rooms (3..8)."""
    cell_size: tuple[float, float] = (3.6, 5.0)
    """Range of the width of a grid column and the height of a grid row (metres)."""
    objects_per_room: tuple[int, int] = (2, 3)
    """Inclusive range of (non-tool) objects placed per room."""
    tools_per_affordance: int = 2
    """Tools placed per affordance; at least 2 so that every tool has a substitute."""
    p_in_container: float = 0.3
    p_door_open: float = 0.6
    p_container_open: float = 0.3
    p_dirty: float = 0.5
    p_keep_door: float = 0.4
    """Chance to keep a door that the 2-edge-connected door graph does not need."""
    door_width: float = 1.0
    distractors: tuple[int, int] = (0, 0)
    """Inclusive range of look-alike objects added: each repeats the category and colour of
    an object already placed, in another room (so "the red mug in the kitchen" still names
    one). Zero keeps every (category, colour) unique."""
    room_items: dict[str, tuple[str, ...]] = {}
    """Object categories each room type tends to hold; each is drawn ``room_item_weight``
    times as often as another there. Empty: every category alike (the dev split)."""
    room_item_weight: float = Field(6.0, ge=1.0)
    furniture_extra: int = Field(0, ge=0, le=3)
    """Optional furniture pieces tried per room beyond each room type's ``optional_count``."""
    furniture: tuple[FurnitureSpec, ...] = DEFAULT_FURNITURE
    items: tuple[ItemSpec, ...] = DEFAULT_ITEMS
    room_furniture: dict[str, RoomFurniture] = DEFAULT_ROOM_FURNITURE
    optional_rooms: tuple[str, ...] = DEFAULT_OPTIONAL_ROOMS
    """Room types beyond kitchen, living_room and storage, drawn without replacement."""

    @classmethod
    def dev(cls) -> HouseParams:
        """The public dev split's houses: 3-5 rooms, every (category, colour) unique."""
        return cls()

    @classmethod
    def standard(cls) -> HouseParams:
        """The standard split's houses: 3-5 rooms, look-alike objects, more of them closed
        away in containers."""
        return cls(distractors=(1, 2), p_in_container=0.5, p_container_open=0.15,
                   room_items=SEMANTIC_ROOM_ITEMS)

    @classmethod
    def challenge(cls) -> HouseParams:
        """The challenge split's houses: 6-8 rooms, more clutter and look-alikes."""
        return cls(rooms=(6, 8), objects_per_room=(2, 4), distractors=(2, 4), furniture_extra=1,
                   p_in_container=0.5, p_container_open=0.15, room_items=SEMANTIC_ROOM_ITEMS)

    @model_validator(mode="after")
    def _check(self) -> HouseParams:
        lo, hi = self.rooms
        most = min(MAX_ROOMS, len(REQUIRED_ROOMS) + len(self.optional_rooms))
        if not 3 <= lo <= hi <= most:
            raise ValueError(f"rooms must satisfy 3 <= lo <= hi <= {most}, got {self.rooms}")
        if not 3.0 <= self.cell_size[0] <= self.cell_size[1] <= 8.0:
            raise ValueError(f"cell_size must satisfy 3.0 <= lo <= hi <= 8.0, got {self.cell_size}")
        if not 0 <= self.distractors[0] <= self.distractors[1] <= 8:
            raise ValueError(f"distractors must satisfy 0 <= lo <= hi <= 8, got {self.distractors}")
        if self.tools_per_affordance < 2:
            raise ValueError("tools_per_affordance must be >= 2 (every tool needs a substitute)")
        for name in self.optional_rooms:
            if name not in ROOM_TYPES or name in REQUIRED_ROOMS:
                raise ValueError(f"optional room type {name!r} is not one of {ROOM_TYPES[1:5]}")
        known = FURNITURE_CATEGORIES + CONTAINER_CATEGORIES
        for f in self.furniture:
            if f.category not in known:
                raise ValueError(f"furniture category {f.category!r} is not in {known}")
            if (f.opening != "none") != (f.category in CONTAINER_CATEGORIES):
                raise ValueError(f"{f.category!r}: containers open, other furniture does not")
        placed = {f.category for f in self.furniture}
        for room_type, mix in self.room_furniture.items():
            if room_type not in ROOM_TYPES:
                raise ValueError(f"room_furniture key {room_type!r} is not in {ROOM_TYPES}")
            for cat in mix.required + mix.optional:
                if cat not in placed:
                    raise ValueError(f"{room_type}: furniture {cat!r} has no FurnitureSpec")
        for room_type, cats in self.room_items.items():
            bad = [c for c in cats if c not in OBJECT_CATEGORIES]
            if room_type not in ROOM_TYPES or bad:
                raise ValueError(f"room_items[{room_type!r}]: unknown names {bad or room_type}")
        for item in self.items:
            vocab = TOOL_CATEGORIES if item.affordances else OBJECT_CATEGORIES
            if item.category not in vocab:
                raise ValueError(f"item category {item.category!r} is not in {vocab}")
            bad = [c for c in item.colours if c not in COLOURS[1:]]
            bad += [a for a in item.affordances if a not in AFFORDANCES]
            bad += [s for s in item.states if s not in STATES]
            if bad:
                raise ValueError(f"{item.category!r}: unknown names {bad}")
        for aff in {a for i in self.items for a in i.affordances}:
            cats = {i.category for i in self.items if aff in i.affordances}
            if len(cats) < 2:
                raise ValueError(f"affordance {aff!r} needs two tool categories, has {cats}")
        return self

    def furniture_spec(self, category: str) -> FurnitureSpec:
        """The spec of a furniture or container category."""
        return next(f for f in self.furniture if f.category == category)

    def digest(self) -> str:
        """A short hash of the parameters (layouts record it)."""
        text = json.dumps(self.model_dump(mode="json"), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


class Room(BaseModel):
    """One rectangular room made of one or two grid cells."""

    model_config = _frozen()

    id: int
    type: str
    cells: tuple[tuple[int, int], ...]
    """(row, column) grid cells."""
    bounds: tuple[float, float, float, float]
    """x0, y0, x1, y1 of the room, measured to the wall centre lines."""

    @property
    def centre(self) -> tuple[float, float]:
        """The centre of the room's rectangle."""
        x0, y0, x1, y1 = self.bounds
        return ((x0 + x1) / 2, (y0 + y1) / 2)


class Door(BaseModel):
    """A hinged door in a doorway between two rooms."""

    model_config = _frozen()

    id: int
    rooms: tuple[int, int]
    hinge: tuple[float, float]
    yaw: float
    """Direction of the closed panel from the hinge (0 or pi/2: walls are axis-aligned)."""
    width: float
    swing_room: int
    """The room the door opens into."""
    open_angle: float
    """Hinge angle of the open door (+-pi/2)."""
    initial_state: Literal["open", "closed", "locked"]

    @property
    def centre(self) -> tuple[float, float]:
        """The centre of the doorway."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return (self.hinge[0] + c * self.width / 2, self.hinge[1] + s * self.width / 2)

    @property
    def swing_normal(self) -> tuple[float, float]:
        """Unit vector across the doorway, pointing into the swing room."""
        sign = 1.0 if self.open_angle > 0 else -1.0
        return (-math.sin(self.yaw) * sign, math.cos(self.yaw) * sign)

    def swing_distance(self, x: float, y: float) -> float:
        """Distance from a point to the area the panel sweeps (its quarter disc)."""
        return door_swing_distance(self.hinge, self.yaw, self.swing_normal, self.width, x, y)

    def panel_distance(self, x: float, y: float) -> float:
        """Distance from a point to the closed panel (the doorway's segment)."""
        return door_panel_distance(self.hinge, self.yaw, self.width, x, y)

    def approach(self, room: int, distance: float = 0.8) -> tuple[float, float, float]:
        """A pose on ``room``'s side of the doorway, ``distance`` from its centre, facing it.

        On the swing room's side use a distance of 1.3-1.5 m to stay out of the door's way
        (closer, open/close fail with ``blocked_by_robot``; farther, ``out_of_reach``). The
        generator keeps 1.3 m (1.8 m on the swing side) by every doorway free of furniture.
        """
        if room not in self.rooms:
            raise ValueError(f"door {self.id} joins rooms {self.rooms}, not {room}")
        sign = 1.0 if room == self.swing_room else -1.0
        nx, ny = self.swing_normal
        cx, cy = self.centre
        x, y = cx + sign * nx * distance, cy + sign * ny * distance
        return (x, y, math.atan2(cy - y, cx - x))


def door_swing_distance(
    hinge: tuple[float, float],
    yaw: float,
    normal: tuple[float, float],
    width: float,
    x: float,
    y: float,
) -> float:
    """Distance from (x, y) to the quarter disc a door panel sweeps (hinge, closed direction
    ``yaw``, opening towards ``normal``)."""
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = x - hinge[0], y - hinge[1]
    u, v = dx * c + dy * s, dx * normal[0] + dy * normal[1]
    if u >= 0 and v >= 0:
        return max(0.0, math.hypot(u, v) - width)
    if u < 0 <= v:
        return math.hypot(u, max(0.0, v - width))
    if v < 0 <= u:
        return math.hypot(v, max(0.0, u - width))
    return math.hypot(u, v)


def door_panel_distance(
    hinge: tuple[float, float], yaw: float, width: float, x: float, y: float
) -> float:
    """Distance from (x, y) to a closed door panel's segment."""
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = x - hinge[0], y - hinge[1]
    u = min(max(dx * c + dy * s, 0.0), width)
    return math.hypot(dx - u * c, dy - u * s)


class Wall(BaseModel):
    """An axis-aligned wall box (footprint centre and half sizes)."""

    model_config = _frozen()

    centre: tuple[float, float]
    half: tuple[float, float]


class Furniture(BaseModel):
    """A piece of furniture or a container, its back against a wall."""

    model_config = _frozen()

    id: int
    kind: Literal["furniture", "container"]
    category: str
    room: int
    pos: tuple[float, float]
    yaw: float
    """Facing direction of the front is ``yaw + pi/2`` (local +y)."""
    size: tuple[float, float, float]
    opening: Literal["none", "front", "top"]
    initial_state: str
    """``open``/``closed`` for a container; ``dirty``/``clean``/``none`` for furniture."""
    access: tuple[float, float, float]
    """A collision-free robot pose (x, y, yaw) in front of it, facing it."""
    slots: int

    @property
    def front(self) -> tuple[float, float]:
        """Unit vector out of the front face."""
        return (-math.sin(self.yaw), math.cos(self.yaw))

    @property
    def footprint(self) -> tuple[float, float, float, float]:
        """Axis-aligned x0, y0, x1, y1 (yaw is a multiple of pi/2)."""
        w, d, _ = self.size
        quarter = round(self.yaw / (math.pi / 2)) % 2
        hx, hy = (w / 2, d / 2) if quarter == 0 else (d / 2, w / 2)
        return (self.pos[0] - hx, self.pos[1] - hy, self.pos[0] + hx, self.pos[1] + hy)

    def slot_local(self, slot: int) -> tuple[float, float, float]:
        """Position of a slot in the furniture frame (x along, y out of the front, z up)."""
        w, d, h = self.size
        if self.opening == "none":
            nx, ny = _surface_grid(self.size)
            i, j = slot % nx, slot // nx
            band = min(d, SURFACE_BAND)
            return ((i + 0.5) / nx * w - w / 2, d / 2 - (j + 0.5) / ny * band, h)
        if self.opening == "top":
            return (0.0, 0.0, CARCASS)
        nx = max(1, int((w - 2 * CARCASS) / SLOT_PITCH))
        return ((slot + 0.5) / nx * (w - 2 * CARCASS) - (w / 2 - CARCASS), -0.02, CARCASS)

    def slot_world(self, slot: int) -> tuple[float, float, float]:
        """Position of a slot's support point in the house frame."""
        lx, ly, z = self.slot_local(slot)
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return (self.pos[0] + c * lx - s * ly, self.pos[1] + s * lx + c * ly, z)

    @property
    def opening_point(self) -> tuple[float, float, float]:
        """A point just outside the opening (line-of-sight target for its contents)."""
        w, d, h = self.size
        if self.opening == "top":
            return (self.pos[0], self.pos[1], h + 0.05)
        fx, fy = self.front
        return (self.pos[0] + fx * (d / 2 + 0.05), self.pos[1] + fy * (d / 2 + 0.05), h / 2)


def slot_count(size: tuple[float, float, float], opening: str) -> int:
    """Number of placement slots of a receptacle of this size and opening."""
    if opening == "none":
        nx, ny = _surface_grid(size)
        return nx * ny
    if opening == "top":
        return 1
    return max(1, int((size[0] - 2 * CARCASS) / SLOT_PITCH))


def _surface_grid(size: tuple[float, float, float]) -> tuple[int, int]:
    return max(1, int(size[0] / SLOT_PITCH)), max(1, int(min(size[1], SURFACE_BAND) / SLOT_PITCH))


class Item(BaseModel):
    """An object or a tool, starting on or in a receptacle."""

    model_config = _frozen()

    id: int
    kind: Literal["object", "tool"]
    category: str
    colour: str
    shape: Literal["box", "cylinder", "sphere"]
    size: tuple[float, float, float]
    half_height: float
    affordances: tuple[str, ...]
    receptacle: int
    slot: int
    initial_state: str


Entity = Door | Furniture | Item


class HouseLayout(BaseModel):
    """A generated house. Same seed and parameters, same layout (compare ``digest()``)."""

    model_config = _frozen()

    version: int = 1
    seed: int
    params_digest: str
    col_widths: tuple[float, ...]
    row_heights: tuple[float, ...]
    rooms: tuple[Room, ...]
    doors: tuple[Door, ...]
    walls: tuple[Wall, ...]
    furniture: tuple[Furniture, ...]
    items: tuple[Item, ...]
    start: tuple[float, float, float]
    """Robot start pose (x, y, yaw)."""
    start_room: int
    backup_room: int
    """The storage room, where relocated objects go."""

    @cached_property
    def _xs(self) -> list[float]:
        out = [0.0]
        for w in self.col_widths:
            out.append(round(out[-1] + w, 6))
        return out

    @cached_property
    def _ys(self) -> list[float]:
        out = [0.0]
        for h in self.row_heights:
            out.append(round(out[-1] + h, 6))
        return out

    @cached_property
    def _cell_room(self) -> dict[tuple[int, int], int]:
        return {cell: room.id for room in self.rooms for cell in room.cells}

    @cached_property
    def _by_id(self) -> dict[int, Entity]:
        out: dict[int, Entity] = {}
        for group in (self.doors, self.furniture, self.items):
            for e in group:
                out[e.id] = e
        return out

    @property
    def extent(self) -> tuple[float, float]:
        """Width and height of the house (metres)."""
        return (self._xs[-1], self._ys[-1])

    def entity(self, entity_id: int) -> Entity | None:
        """The door, furniture, container, object or tool with this id, or None."""
        return self._by_id.get(entity_id)

    def kind_of(self, entity_id: int) -> str | None:
        """``door``, ``furniture``, ``container``, ``object``, ``tool``, or None."""
        e = self._by_id.get(entity_id)
        if e is None:
            return None
        return "door" if isinstance(e, Door) else e.kind

    def room_at(self, x: float, y: float) -> int:
        """The room whose cell contains the point (clamped to the house)."""
        col = min(max(bisect.bisect_right(self._xs, x) - 1, 0), len(self.col_widths) - 1)
        row = min(max(bisect.bisect_right(self._ys, y) - 1, 0), len(self.row_heights) - 1)
        return self._cell_room[(row, col)]

    def edges(self) -> list[tuple[int, int, int]]:
        """Room graph edges as (room_a, room_b, door_id), a < b."""
        return [(min(d.rooms), max(d.rooms), d.id) for d in self.doors]

    def item_position(self, item: Item, receptacle: int, slot: int) -> tuple[float, float, float]:
        """Centre of an item resting in a receptacle slot."""
        rec = self._by_id[receptacle]
        assert isinstance(rec, Furniture)
        x, y, z = rec.slot_world(slot)
        return (x, y, z + item.half_height + 0.002)

    def digest(self) -> str:
        """sha256 of the layout's canonical JSON."""
        text = json.dumps(self.model_dump(mode="json"), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()
