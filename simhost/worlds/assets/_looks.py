"""The proposed dressing: which meshes and textures show each catalogue category and part.

A :class:`Look` is a list of visual-only :class:`Part` s in the frame of the entity's body as
``simhost/worlds/track1/_mjcf.py`` builds it today: furniture and containers stand on z = 0, width
along x, depth along y, front towards +y; an item is centred on its body; a container's lid
parts are centred on the lid body. A part's ``rgba`` of ``None`` takes the catalogue colour
of the entity (``RGBA[colour]``), multiplied onto its texture, so that two look-alikes differ
only where the catalogue says they do. Track 2 parts are unit meshes, to scale per instance.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

_DIR = Path(__file__).resolve().parent
Vec = tuple[float, float, float]
RGBA = tuple[float, float, float, float]

WOOD: RGBA = (1.0, 1.0, 1.0, 1.0)
PALE: RGBA = (0.95, 0.95, 0.92, 1.0)
METAL: RGBA = (0.85, 0.86, 0.88, 1.0)
DARK: RGBA = (0.25, 0.25, 0.27, 1.0)


@dataclass(frozen=True)
class Part:
    """One visual-only geom: a mesh (or a box when ``mesh`` is None) and its material."""

    mesh: str | None
    """File name in ``meshes/`` (``None``: a box geom filling ``box``)."""
    texture: str | None
    """File name in ``textures/``; a mesh takes it as a ``cube`` texture (no UVs needed)."""
    rgba: RGBA | None = WOOD
    """Material colour; ``None``: the entity's catalogue colour."""
    box: tuple[Vec, Vec] | None = None
    """(lo, hi) corners the mesh is scaled into; ``None``: the mesh as it is (generated meshes
    are made in this frame and size)."""
    turn: float = 0.0
    """Degrees about z applied to the mesh before fitting (90-degree steps)."""
    pre_x: float = 0.0
    """Degrees about x applied first (90-degree steps), for meshes lying in another plane."""


@dataclass(frozen=True)
class Look:
    """How one category looks: its body's parts and its lid's (containers)."""

    parts: tuple[Part, ...]
    lid: tuple[Part, ...] = ()


def _gen(name: str, texture: str | None, rgba: RGBA | None = WOOD) -> Part:
    return Part(f"{name}.obj", texture, rgba)


def _case(w: float, d: float, h: float, texture: str = "wood_light.png",
          rgba: RGBA = WOOD) -> tuple[Part, ...]:
    """An open-front case of panels at a container's default size (front +y): the package
    case meshes carry an inner floor above where the house puts the things inside, and the
    generated fridge body is a closed shell; either would hide those things from the camera
    while they are in view. The bottom panel's top stays below the carcass the things stand
    on (0.03 m) at any size up to 1.2x."""
    t, b = 0.03, 0.025
    boxes = (
        ((-w / 2, -d / 2, 0.0), (w / 2, d / 2, b)),  # bottom
        ((-w / 2, -d / 2, 0.0), (w / 2, -d / 2 + t, h)),  # back
        ((-w / 2, -d / 2, 0.0), (-w / 2 + t, d / 2, h)),  # sides
        ((w / 2 - t, -d / 2, 0.0), (w / 2, d / 2, h)),
        ((-w / 2, -d / 2, h - t), (w / 2, d / 2, h)),  # top
    )
    return tuple(Part(None, texture, rgba, box) for box in boxes)


_TABLE = (
    Part("mw_table_top.stl", "wood_light.png", WOOD, ((-0.6, -0.4, 0.71), (0.6, 0.4, 0.75)), 90),
    Part("mw_table_legs.stl", "wood_dark.png", WOOD, ((-0.56, -0.36, 0.0), (0.56, 0.36, 0.71))),
)
_DESK = (
    Part("mw_table_top.stl", "wood_light.png", WOOD, ((-0.6, -0.3, 0.71), (0.6, 0.3, 0.75)), 90),
    Part("mw_table_legs.stl", "wood_dark.png", WOOD, ((-0.56, -0.26, 0.0), (0.56, 0.26, 0.71))),
    Part(
        "mw_drawer_case.stl", "wood_light.png", WOOD, ((0.15, -0.28, 0.3), (0.58, 0.28, 0.71)), 180
    ),
)

TRACK1_LOOKS: dict[str, Look] = {
    "door": Look(
        (
            Part("door_leaf.obj", "wood_dark.png", WOOD),
            Part(
                "gk_door_handle.stl",
                "steel_brushed.png",
                METAL,
                ((0.36, 0.025, -0.1), (0.4, 0.1, 0.2)),
            ),
            Part(
                "gk_door_handle.stl",
                "steel_brushed.png",
                METAL,
                ((0.36, -0.1, -0.1), (0.4, -0.025, 0.2)),
                180,
            ),
        )
    ),
    "table": Look(_TABLE),
    "desk": Look(_DESK),
    "counter": Look(
        (
            Part(
                "gk_counter_cabinet.stl",
                "wood_light.png",
                WOOD,
                ((-0.8, -0.3, 0.0), (0.8, 0.28, 0.86)),
                180,
            ),
            Part(None, "marble_counter.png", WOOD, ((-0.8, -0.3, 0.86), (0.8, 0.3, 0.9))),
        )
    ),
    "shelf": Look(
        (
            Part(
                "mw_bookcase.stl", "wood_light.png", WOOD, ((-0.5, -0.2, 0.0), (0.5, 0.2, 1.1)), 180
            ),
        )
    ),
    "bed": Look(
        (
            _gen("bed_frame", "wood_dark.png"),
            _gen("bed_mattress", "fabric_felt.png", PALE),
            _gen("bed_pillows", "fabric_felt.png", PALE),
            _gen("bed_blanket", "fabric_felt.png", (0.45, 0.55, 0.75, 1.0)),
        )
    ),
    "sofa": Look(
        (
            _gen("sofa_body", "fabric_felt.png", (0.55, 0.5, 0.45, 1.0)),
            _gen("sofa_cushions", "fabric_felt.png", (0.62, 0.57, 0.5, 1.0)),
        )
    ),
    "cabinet": Look(
        _case(0.8, 0.5, 0.9),
        lid=(
            Part(
                "gk_cabinet_door.stl",
                "wood_light.png",
                WOOD,
                ((-0.4, -0.015, -0.45), (0.4, 0.015, 0.45)),
            ),
            Part(
                "gk_door_handle.stl",
                "steel_brushed.png",
                METAL,
                ((0.28, 0.015, -0.15), (0.32, 0.07, 0.15)),
            ),
        ),
    ),
    "drawer": Look(
        _case(0.7, 0.5, 0.7),
        lid=(_gen("drawer_fronts", "wood_light.png"),)
        + tuple(
            Part(
                "mw_drawer_handle.stl",
                "steel_brushed.png",
                METAL,
                ((-0.09, 0.015, z - 0.012), (0.09, 0.05, z + 0.012)),
                180,
            )
            for z in (-0.234, 0.0, 0.234)
        ),
    ),
    "fridge": Look(
        _case(0.7, 0.7, 1.8, "steel_brushed.png", METAL),
        lid=(
            _gen("fridge_doors", "steel_brushed.png", METAL),
            Part(
                "gk_bar_handle.stl",
                "steel_brushed.png",
                DARK,
                ((-0.3, 0.015, -0.5), (-0.26, 0.09, 0.1)),
                90,
                90,
            ),
            Part(
                "gk_bar_handle.stl",
                "steel_brushed.png",
                DARK,
                ((-0.3, 0.015, 0.45), (-0.26, 0.09, 0.8)),
                90,
                90,
            ),
        ),
    ),
    "bin": Look(
        (_gen("bin_body", "steel_brushed.png", METAL),),
        lid=(_gen("bin_lid", "steel_brushed.png", METAL),),
    ),
    "mug": Look(
        (
            Part("mw_mug.stl", "ceramic.png", None, ((-0.04, -0.04, -0.05), (0.04, 0.04, 0.05))),
            Part(
                "mw_mug_handle.stl",
                "ceramic.png",
                None,
                ((0.035, -0.004, -0.03), (0.065, 0.004, 0.03)),
                0,
                90,
            ),
        )
    ),
    "apple": Look((_gen("apple", None, None),)),
    "book": Look((_gen("book_cover", "fabric_felt.png", None), _gen("book_pages", None, PALE))),
    "plate": Look((_gen("plate", "ceramic.png", None),)),
    "towel": Look((_gen("towel", "fabric_felt.png", None),)),
    "bottle": Look(
        (Part("rs_bottle.obj", "glass.png", None, ((-0.035, -0.035, -0.1), (0.035, 0.035, 0.1))),)
    ),
    "bowl": Look((_gen("bowl", "ceramic.png", None),)),
    "bread": Look(
        (Part("rs_bread.obj", "bread.png", None, ((-0.1, -0.05, -0.04), (0.1, 0.05, 0.04)), 90),)
    ),
    "plant": Look((_gen("plant_pot", "clay.png"), _gen("plant_leaves", None, None))),
    "sponge": Look(
        (
            _gen("sponge_foam", "fabric_felt.png", None),
            _gen("sponge_scourer", "fabric_felt.png", (0.1, 0.35, 0.15, 1.0)),
        )
    ),
    "cloth": Look((_gen("cloth", "fabric_felt.png", None),)),
    "knife": Look(
        (_gen("knife_blade", "steel_brushed.png", METAL), _gen("knife_handle", None, None))
    ),
    "scissors": Look(
        (_gen("scissors_blades", "steel_brushed.png", METAL), _gen("scissors_handles", None, None))
    ),
    "watering_can": Look((_gen("watering_can", None, None),)),
    "jug": Look((_gen("jug", "ceramic.png", None),)),
}
"""Every Track 1 category (``CATEGORIES``) and the parts that show it."""

FLOORS: dict[str, str] = {
    "kitchen": "floor_tile_marble.png",
    "living_room": "floor_wood_planks.png",
    "bedroom": "floor_wood_planks.png",
    "bathroom": "floor_tile_mosaic.png",
    "hallway": "floor_tile_grey.png",
    "storage": "floor_tile_grey.png",
}
"""Floor texture by room type (tinted by ``ROOM_FLOOR_RGBA``, so rooms stay told apart)."""
WALLS: tuple[str, ...] = ("wall_plaster_white.png", "wall_plaster_cream.png")
"""Wall textures (a house may alternate them by room)."""

TRACK2_LOOKS: dict[str, Part] = {
    "table": Part(None, "wood_table.png"),
    "peg/square": Part("peg_square.obj", "brass.png"),
    "peg/rect": Part("peg_square.obj", "brass.png"),
    "peg/round": Part("peg_round.obj", "brass.png"),
    "peg/hex": Part("peg_hex.obj", "brass.png"),
    "hole": Part(None, "wood_dark.png"),
    "knob/knob": Part("gk_knob.stl", "steel_brushed.png", DARK),
    "knob/valve": Part(None, "steel_brushed.png", (0.8, 0.2, 0.2, 1.0)),
    "knob/nut": Part("hex_nut.obj", "steel_brushed.png", METAL),
    "base/nut": Part("bolt.obj", "steel_brushed.png", METAL),
    "base": Part(None, "steel_brushed.png", METAL),
    "mover/drawer": Part(None, "wood_light.png"),
    "mover/drawer handle": Part("gk_bar_handle.stl", "steel_brushed.png", METAL),
    "mover/sliding_cover": Part(None, "wood_light.png"),
    "mover/swivel_lid": Part(None, "wood_light.png"),
    "mover/knob": Part("gk_knob.stl", "steel_brushed.png", DARK),
    "housing": Part(None, "wood_dark.png"),
    "tray": Part(None, "steel_brushed.png", METAL),
    "part1..3": Part(None, "wood_light.png", None),
    "tool/handle": Part(None, "wood_dark.png"),
    "tool/shaft": Part(None, "steel_brushed.png", METAL),
    "target/button": Part(None, None, (0.9, 0.1, 0.1, 1.0)),
    "target/puck": Part(None, "wood_dark.png"),
    "fixture": Part(None, "steel_brushed.png", METAL),
}
"""Track 2 part (``part`` or ``part/kind``) -> its look; ``None`` mesh: texture the part's own
primitive; a unit mesh is scaled to the part's size per instance."""


# -- fitting a mesh into its box ---------------------------------------------------------------
def mesh_vertices(name: str) -> np.ndarray:
    """The vertices of ``meshes/<name>`` (binary STL or OBJ), in the file's frame."""
    data = (_DIR / "meshes" / name).read_bytes()
    if name.endswith(".obj"):
        rows = [line.split()[1:4] for line in data.decode().splitlines() if line.startswith("v ")]
        return np.array(rows, float)
    (count,) = struct.unpack("<I", data[80:84])
    record = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    return np.frombuffer(data[84 : 84 + 50 * count], record)["v"].reshape(-1, 3).astype(float)


def mesh_bounds(name: str) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) corners of the mesh's bounding box in its file's frame."""
    v = mesh_vertices(name)
    return v.min(axis=0), v.max(axis=0)


@dataclass(frozen=True)
class Fit:
    """How to place a part: the ``<mesh scale>`` and the geom's ``pos`` and ``quat``."""

    scale: Vec
    pos: Vec
    quat: tuple[float, float, float, float]


def _rotation(part: Part) -> np.ndarray:
    cx, sx = round(math.cos(math.radians(part.pre_x))), round(math.sin(math.radians(part.pre_x)))
    cz, sz = round(math.cos(math.radians(part.turn))), round(math.sin(math.radians(part.turn)))
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]], float)
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]], float)
    return rz @ rx


def _quat(r: np.ndarray) -> tuple[float, float, float, float]:
    w = math.sqrt(max(0.0, 1 + r[0, 0] + r[1, 1] + r[2, 2])) / 2
    if w > 1e-6:
        return (
            w,
            (r[2, 1] - r[1, 2]) / (4 * w),
            (r[0, 2] - r[2, 0]) / (4 * w),
            (r[1, 0] - r[0, 1]) / (4 * w),
        )
    x = math.sqrt(max(0.0, 1 + r[0, 0] - r[1, 1] - r[2, 2])) / 2
    if x > 1e-6:
        return (0.0, x, (r[0, 1] + r[1, 0]) / (4 * x), (r[0, 2] + r[2, 0]) / (4 * x))
    y = math.sqrt(max(0.0, 1 - r[0, 0] + r[1, 1] - r[2, 2])) / 2
    if y > 1e-6:
        return (0.0, (r[0, 1] + r[1, 0]) / (4 * y), y, (r[1, 2] + r[2, 1]) / (4 * y))
    return (0.0, 0.0, 0.0, 1.0)


def fit(part: Part) -> Fit:
    """Scale, position and orientation that put ``part``'s mesh exactly into its box (turned
    first), or leave a generated mesh where it was made."""
    if part.mesh is None:
        raise ValueError("a box part has no mesh to fit: make a box geom of its box")
    r = _rotation(part)
    if part.box is None:
        return Fit((1.0, 1.0, 1.0), (0.0, 0.0, 0.0), _quat(r))
    lo, hi = mesh_bounds(part.mesh)
    size_file = hi - lo
    target = np.array(part.box[1]) - np.array(part.box[0])
    # the file axis each box axis comes from (the rotation permutes axes)
    axis_of = np.abs(r).argmax(axis=1)
    scale = np.ones(3)
    for box_axis, file_axis in enumerate(axis_of):
        scale[file_axis] = target[box_axis] / size_file[file_axis]
    centre_file = (lo + hi) / 2 * scale
    pos = (np.array(part.box[0]) + np.array(part.box[1])) / 2 - r @ centre_file
    return Fit(tuple(scale), tuple(pos), _quat(r))  # type: ignore[arg-type]
