"""EAGC Track 1 environment: procedurally generated MuJoCo houses and a mobile robot.

Light on import: the generator, layouts, tasks, vocabularies and top-down pictures need only
numpy and pydantic. ``HouseEnv``, ``House`` and ``HouseSim`` load MuJoCo (and set
``MUJOCO_GL=egl`` unless already set) on first access. Importing this package registers
``eagc/HouseDev-v0``, ``eagc/House-v0``, ``eagc/HouseChallenge-v0`` and
``eagc/HouseVision-v0`` (one per split of ``SPLITS``) with Gymnasium.

    >>> from simhost.worlds.track1 import HouseEnv, make_action
    >>> env = HouseEnv()
    >>> obs, info = env.reset(seed=7)
    >>> obs, reward, terminated, truncated, info = env.step(make_action("move", forward=1.0))
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ._actions import (
    PRIMITIVES,
    REASONS,
    ActionResult,
    Pixel,
    make_action,
    make_pixel_action,
    parse_action,
    parse_pixel_action,
)
from ._catalogue import (
    AFFORDANCE_EFFECTS,
    AFFORDANCES,
    CATEGORIES,
    COLOURS,
    CONFUSABLE,
    CONFUSABLE_COLOURS,
    CONTAINER_CATEGORIES,
    FURNITURE_CATEGORIES,
    KINDS,
    MAX_IDS,
    MAX_ROOMS,
    OBJECT_CATEGORIES,
    ROOM_TYPES,
    STATES,
    TOOL_CATEGORIES,
    FurnitureSpec,
    ItemSpec,
    RoomFurniture,
)
from ._config import HouseEnvConfig
from ._errors import (
    ConfigError,
    HouseError,
    LayoutError,
    PerturbationError,
    StateError,
    TaskError,
)
from ._generate import generate_house
from ._graph import doors_on_path, is_two_edge_connected, shortest_room_path
from ._info import HouseInfo
from ._layout import Door, Furniture, HouseLayout, HouseParams, Item, Room, Wall
from ._register import (
    CHALLENGE_ENV_ID,
    DEV_ENV_ID,
    ENV_ID,
    ENV_IDS,
    VISION_ENV_ID,
    register_envs,
)
from ._splits import SPLITS, HouseSplit, house_split
from ._task import HouseTask
from ._topdown import (
    TOPDOWN_LEGEND,
    TOPDOWN_MARGIN,
    TOPDOWN_SCALE,
    draw_text,
    render_topdown,
    write_png,
)
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
from ._world import WorldState, ground_truth

if TYPE_CHECKING:
    from ._env import HouseEnv
    from ._house import House
    from ._sim import HouseSim

_LAZY = {"HouseEnv": "._env", "House": "._house", "HouseSim": "._sim"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def initial_ground_truth(layout: HouseLayout) -> HouseTruth:
    """Ground truth of a layout's initial state (no MuJoCo needed; robot at the start)."""
    return ground_truth(layout, WorldState.initial(layout), layout.start, (0.0, 0.0, 0.0))


register_envs()

__all__ = [
    "AFFORDANCES",
    "AFFORDANCE_EFFECTS",
    "CATEGORIES",
    "CHALLENGE_ENV_ID",
    "COLOURS",
    "CONFUSABLE",
    "CONFUSABLE_COLOURS",
    "CONTAINER_CATEGORIES",
    "DEV_ENV_ID",
    "ENV_ID",
    "ENV_IDS",
    "FURNITURE_CATEGORIES",
    "KINDS",
    "MAX_IDS",
    "MAX_ROOMS",
    "OBJECT_CATEGORIES",
    "PRIMITIVES",
    "REASONS",
    "ROOM_TYPES",
    "SPLITS",
    "STATES",
    "TOPDOWN_LEGEND",
    "TOPDOWN_MARGIN",
    "TOPDOWN_SCALE",
    "TOOL_CATEGORIES",
    "VISION_ENV_ID",
    "ActionResult",
    "AffordanceTruth",
    "ConfigError",
    "ConnectionTruth",
    "Door",
    "DoorTruth",
    "Furniture",
    "FurnitureSpec",
    "FurnitureTruth",
    "House",
    "HouseEnv",
    "HouseEnvConfig",
    "HouseError",
    "HouseInfo",
    "HouseLayout",
    "HouseParams",
    "HouseSim",
    "HouseSplit",
    "HouseTask",
    "HouseTruth",
    "Item",
    "ItemSpec",
    "LayoutError",
    "ObjectTruth",
    "PerturbationError",
    "Pixel",
    "RobotTruth",
    "Room",
    "RoomFurniture",
    "RoomTruth",
    "StateError",
    "TaskError",
    "ToolTruth",
    "Wall",
    "WorldState",
    "doors_on_path",
    "draw_text",
    "generate_house",
    "ground_truth",
    "house_split",
    "initial_ground_truth",
    "is_two_edge_connected",
    "make_action",
    "make_pixel_action",
    "parse_action",
    "parse_pixel_action",
    "register_envs",
    "render_topdown",
    "shortest_room_path",
    "write_png",
]
