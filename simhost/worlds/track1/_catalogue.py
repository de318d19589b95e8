"""Public vocabularies and the default catalogue of the Track 1 house.

The vocabularies are fixed tuples: an observation carries an index into them, so their
order is part of the observation contract (append, never reorder or remove). An organizer
parameter pack may choose among these names, sizes and mixes, but may not invent names.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict

from simhost.client._lookalikes import CONFUSABLE as CONFUSABLE
from simhost.client._lookalikes import CONFUSABLE_COLOURS as CONFUSABLE_COLOURS

ROOM_TYPES: tuple[str, ...] = (
    "kitchen",
    "living_room",
    "bedroom",
    "bathroom",
    "hallway",
    "storage",
)
"""Room types; ``storage`` is the backup area (one per house)."""

KINDS: tuple[str, ...] = ("door", "furniture", "container", "object", "tool")
"""Entity kinds. Every entity of these kinds has an instance id."""

FURNITURE_CATEGORIES: tuple[str, ...] = ("table", "counter", "shelf", "bed", "desk", "sofa")
CONTAINER_CATEGORIES: tuple[str, ...] = ("cabinet", "drawer", "fridge", "bin")
OBJECT_CATEGORIES: tuple[str, ...] = (
    "mug",
    "apple",
    "book",
    "plate",
    "towel",
    "bottle",
    "bowl",
    "bread",
    "plant",
)
TOOL_CATEGORIES: tuple[str, ...] = ("sponge", "cloth", "knife", "scissors", "watering_can", "jug")

CATEGORIES: tuple[str, ...] = (
    ("door",) + FURNITURE_CATEGORIES + CONTAINER_CATEGORIES + OBJECT_CATEGORIES + TOOL_CATEGORIES
)
"""Every category; ``det_category`` indexes this tuple."""

COLOURS: tuple[str, ...] = (
    "none",
    "red",
    "green",
    "blue",
    "yellow",
    "white",
    "black",
    "orange",
    "purple",
)
"""Colours; ``det_colour`` indexes this tuple (``none`` for uncoloured entities)."""

STATES: tuple[str, ...] = (
    "none",
    "open",
    "closed",
    "locked",
    "unavailable",
    "dirty",
    "clean",
    "whole",
    "sliced",
    "dry",
    "watered",
)
"""Visible states; ``det_state`` indexes this tuple."""

AFFORDANCES: tuple[str, ...] = ("wipe", "cut", "water")
"""Tool affordances."""

AFFORDANCE_EFFECTS: dict[str, tuple[str, str]] = {
    "wipe": ("dirty", "clean"),
    "cut": ("whole", "sliced"),
    "water": ("dry", "watered"),
}
"""For each affordance, the (before, after) state of a target it applies to."""

RGBA: dict[str, tuple[float, float, float, float]] = {
    "none": (0.6, 0.6, 0.6, 1.0),
    "red": (0.85, 0.15, 0.15, 1.0),
    "green": (0.15, 0.7, 0.2, 1.0),
    "blue": (0.15, 0.3, 0.85, 1.0),
    "yellow": (0.95, 0.85, 0.15, 1.0),
    "white": (0.95, 0.95, 0.95, 1.0),
    "black": (0.1, 0.1, 0.1, 1.0),
    "orange": (0.95, 0.55, 0.1, 1.0),
    "purple": (0.55, 0.2, 0.7, 1.0),
}


class FurnitureSpec(BaseModel):
    """One furniture or container category: its box and how it opens."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    category: str
    """A name from ``FURNITURE_CATEGORIES`` or ``CONTAINER_CATEGORIES``."""
    size: tuple[float, float, float]
    """Width along the wall, depth into the room, height (metres)."""
    opening: Literal["none", "front", "top"] = "none"
    """``none`` for a plain surface, else the side a container opens on."""
    wipeable: bool = False
    """Whether its top can be dirty (target of ``wipe``)."""


class ItemSpec(BaseModel):
    """One object or tool category: shape, colours and where it may be placed."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    category: str
    """A name from ``OBJECT_CATEGORIES`` or ``TOOL_CATEGORIES``."""
    shape: Literal["box", "cylinder", "sphere"]
    size: tuple[float, float, float]
    """Half sizes (box), or (radius, half height, 0) for a cylinder, (radius, 0, 0) a sphere."""
    colours: tuple[str, ...]
    receptacles: tuple[str, ...]
    """Furniture or container categories it may start on or in."""
    affordances: tuple[str, ...] = ()
    """Non-empty for a tool."""
    states: tuple[str, ...] = ()
    """(before, after) states when an affordance applies to it, else empty."""

    @property
    def half_height(self) -> float:
        """Half of the item's height."""
        if self.shape == "sphere":
            return self.size[0]
        return self.size[1] if self.shape == "cylinder" else self.size[2]


class RoomFurniture(BaseModel):
    """The furniture mix of a room type."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    required: tuple[str, ...] = ()
    optional: tuple[str, ...] = ()
    optional_count: tuple[int, int] = (1, 2)
    """How many optional pieces to try to add (inclusive range)."""


DEFAULT_FURNITURE: tuple[FurnitureSpec, ...] = (
    FurnitureSpec(category="table", size=(1.2, 0.8, 0.75), wipeable=True),
    FurnitureSpec(category="counter", size=(1.6, 0.6, 0.9), wipeable=True),
    FurnitureSpec(category="shelf", size=(1.0, 0.4, 1.1)),
    FurnitureSpec(category="bed", size=(1.4, 1.9, 0.5)),
    FurnitureSpec(category="desk", size=(1.2, 0.6, 0.75), wipeable=True),
    FurnitureSpec(category="sofa", size=(1.8, 0.8, 0.45)),
    FurnitureSpec(category="cabinet", size=(0.8, 0.5, 0.9), opening="front"),
    FurnitureSpec(category="drawer", size=(0.7, 0.5, 0.7), opening="front"),
    FurnitureSpec(category="fridge", size=(0.7, 0.7, 1.8), opening="front"),
    FurnitureSpec(category="bin", size=(0.45, 0.45, 0.5), opening="top"),
)

_ANY = ("red", "green", "blue", "yellow", "white", "black", "orange", "purple")
_SURFACES = ("table", "counter", "shelf", "desk")

DEFAULT_ITEMS: tuple[ItemSpec, ...] = (
    ItemSpec(
        category="mug",
        shape="cylinder",
        size=(0.04, 0.05, 0),
        colours=_ANY,
        receptacles=_SURFACES + ("cabinet",),
    ),
    ItemSpec(
        category="apple",
        shape="sphere",
        size=(0.04, 0, 0),
        colours=("red", "green", "yellow"),
        receptacles=("table", "counter", "fridge"),
        states=("whole", "sliced"),
    ),
    ItemSpec(
        category="book",
        shape="box",
        size=(0.1, 0.07, 0.02),
        colours=_ANY,
        receptacles=("shelf", "table", "desk", "bed", "sofa", "drawer"),
    ),
    ItemSpec(
        category="plate",
        shape="cylinder",
        size=(0.1, 0.01, 0),
        colours=("white", "blue", "red", "yellow"),
        receptacles=("table", "counter", "cabinet"),
    ),
    ItemSpec(
        category="towel",
        shape="box",
        size=(0.12, 0.09, 0.02),
        colours=_ANY,
        receptacles=("shelf", "bed", "counter", "drawer", "cabinet"),
    ),
    ItemSpec(
        category="bottle",
        shape="cylinder",
        size=(0.035, 0.1, 0),
        colours=("green", "blue", "white", "orange"),
        receptacles=("fridge", "counter", "table", "cabinet"),
    ),
    ItemSpec(
        category="bowl",
        shape="cylinder",
        size=(0.07, 0.03, 0),
        colours=("white", "blue", "red", "green"),
        receptacles=("table", "counter", "cabinet"),
    ),
    ItemSpec(
        category="bread",
        shape="box",
        size=(0.1, 0.05, 0.04),
        colours=("orange", "yellow"),
        receptacles=("counter", "table", "fridge"),
        states=("whole", "sliced"),
    ),
    ItemSpec(
        category="plant",
        shape="cylinder",
        size=(0.07, 0.12, 0),
        colours=("green",),
        receptacles=("table", "shelf", "desk", "counter"),
        states=("dry", "watered"),
    ),
    ItemSpec(
        category="sponge",
        shape="box",
        size=(0.05, 0.035, 0.02),
        colours=("yellow", "green", "blue"),
        receptacles=("counter", "cabinet", "shelf"),
        affordances=("wipe",),
    ),
    ItemSpec(
        category="cloth",
        shape="box",
        size=(0.1, 0.1, 0.01),
        colours=("white", "blue", "red"),
        receptacles=("counter", "drawer", "shelf", "table"),
        affordances=("wipe",),
    ),
    ItemSpec(
        category="knife",
        shape="box",
        size=(0.1, 0.015, 0.01),
        colours=("black", "white"),
        receptacles=("counter", "drawer", "table"),
        affordances=("cut",),
    ),
    ItemSpec(
        category="scissors",
        shape="box",
        size=(0.075, 0.03, 0.01),
        colours=("red", "black", "blue"),
        receptacles=("desk", "drawer", "shelf", "table"),
        affordances=("cut",),
    ),
    ItemSpec(
        category="watering_can",
        shape="cylinder",
        size=(0.07, 0.09, 0),
        colours=("green", "blue", "orange"),
        receptacles=("shelf", "counter", "table"),
        affordances=("water",),
    ),
    ItemSpec(
        category="jug",
        shape="cylinder",
        size=(0.05, 0.1, 0),
        colours=("white", "blue"),
        receptacles=("counter", "table", "cabinet", "fridge"),
        affordances=("water",),
    ),
)

DEFAULT_ROOM_FURNITURE: dict[str, RoomFurniture] = {
    "kitchen": RoomFurniture(
        required=("counter", "fridge", "cabinet"),
        optional=("table", "drawer", "bin"),
        optional_count=(1, 2),
    ),
    "living_room": RoomFurniture(required=("sofa", "table"), optional=("shelf", "cabinet", "bin")),
    "bedroom": RoomFurniture(required=("bed",), optional=("desk", "drawer", "shelf")),
    "bathroom": RoomFurniture(required=("cabinet",), optional=("counter", "bin", "shelf")),
    "hallway": RoomFurniture(
        required=(), optional=("shelf", "table", "cabinet"), optional_count=(1, 1)
    ),
    "storage": RoomFurniture(
        required=("shelf", "cabinet"), optional=("shelf", "bin", "drawer"), optional_count=(1, 1)
    ),
}

SEMANTIC_ROOM_ITEMS: dict[str, tuple[str, ...]] = {
    "kitchen": ("apple", "bread", "mug", "plate", "bowl", "bottle"),
    "living_room": ("book", "plant", "mug", "bowl"),
    "bedroom": ("book", "towel", "plant"),
    "bathroom": ("towel", "bottle"),
    "hallway": ("plant", "book"),
    "storage": ("bottle", "towel", "plate"),
}
"""Object categories each room type tends to hold (the official splits weight them, so that
a house is as regular as a real one and priors learned offline carry over)."""

DEFAULT_OPTIONAL_ROOMS: tuple[str, ...] = ("bedroom", "bathroom", "hallway", "bedroom", "bathroom")
"""Room types added, without replacement and in a seeded order, beyond the three required
ones (kitchen, living_room, storage)."""

REQUIRED_ROOMS: tuple[str, ...] = ("kitchen", "living_room", "storage")

ROOM_FLOOR_RGBA: dict[str, tuple[float, float, float, float]] = {
    "kitchen": (0.86, 0.84, 0.72, 1.0),
    "living_room": (0.78, 0.70, 0.58, 1.0),
    "bedroom": (0.74, 0.80, 0.88, 1.0),
    "bathroom": (0.76, 0.88, 0.86, 1.0),
    "hallway": (0.82, 0.82, 0.82, 1.0),
    "storage": (0.70, 0.70, 0.66, 1.0),
}

MAX_IDS = 256
"""Instance ids are in ``[1, MAX_IDS)``; 0 is never an instance id."""

MAX_ROOMS = 8
