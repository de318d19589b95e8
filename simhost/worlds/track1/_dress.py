"""What the camera draws: the house dressed in the asset library's textures and meshes.

The primitive geoms of ``_mjcf.py`` (walls, doors, carcasses, lids, items) decide collisions,
rays and physics; the camera does not draw them. It draws only :data:`VISUAL_GROUP`, which
holds the textured floors and, for every primitive the robot could see, visual-only twins:
plastered walls, panelled wooden doors with handles, and each furniture, container, lid,
object and tool as the parts of its look in ``simhost.worlds.assets.TRACK1_LOOKS``. A twin has no
contact (``contype="0" conaffinity="0"``), no mass (``density="0"``) and sits in a group
neither of ``_sim.py``'s ray masks reads, so nothing the simulation decides changes.

Each twin is named after its entity (``furn_<id>_v<k>``, ``lid_<id>_v<k>``, ``item_<id>_v<k>``,
``door_<id>_v<k>``, ``doorlamp_<id>_v``) so that the segmentation image maps it to the
entity's instance id like its primitive. Looks are made at the catalogue's default sizes and
scaled per axis to an entity's own size (a parameter pack may change sizes). A catalogue
colour multiplies onto a light, neutral texture: two entities of one category differ only in
the colour the detector reports.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

from simhost.worlds.assets import ASSET_DIR, FLOORS, TRACK1_LOOKS, WALLS, Look, Part, fit

from ._catalogue import DEFAULT_FURNITURE, DEFAULT_ITEMS, RGBA
from ._layout import DOOR_HEIGHT, Door, Furniture, Item

VISUAL_GROUP = 4
"""The only geom group the camera draws (floors and visual twins); no ray reads it."""
VISUAL = f'contype="0" conaffinity="0" density="0" group="{VISUAL_GROUP}"'
WALL_RGBA = (0.92, 0.91, 0.88, 1.0)
DOOR_LEAF_SIZE = (0.96, 0.062, 1.98)
"""Extent of ``door_leaf.obj`` (a 1 m doorway's leaf)."""
_FLOOR_REPEAT = {"floor_tile_mosaic.png": 1.0}
_FLAT_TINT = {
    "wood_light.png": (0.78, 0.62, 0.44, 1.0),
    "steel_brushed.png": (0.72, 0.73, 0.75, 1.0),
}
"""Large flat meshes (cabinet, fridge and drawer fronts) in a plain tint of their texture: a
cube-mapped texture streaks radially across them (``simhost/worlds/assets/README.md``)."""
_FLAT_MESHES = frozenset({"gk_cabinet_door.stl", "fridge_doors.obj", "drawer_fronts.obj"})
"""Texture repeats per metre on floors (default 0.5: one image per 2 m)."""

Vec = tuple[float, float, float]
RGBA_T = tuple[float, float, float, float]
LAMP_OFF = "0.2 0.75 0.3 1"


def _f(*values: float) -> str:
    return " ".join(f"{v:.5g}" for v in values)


def _extent(shape: str, size: tuple[float, float, float]) -> Vec:
    """Full extent (x, y, z) of an item primitive from its catalogue size."""
    if shape == "sphere":
        return (2 * size[0],) * 3
    if shape == "cylinder":
        return (2 * size[0], 2 * size[0], 2 * size[1])
    return (2 * size[0], 2 * size[1], 2 * size[2])


_FURNITURE_SIZE = {spec.category: spec.size for spec in DEFAULT_FURNITURE}
_ITEM_EXTENT = {spec.category: _extent(spec.shape, spec.size) for spec in DEFAULT_ITEMS}


def _ratio(size: Vec, default: Vec) -> Vec:
    return (size[0] / default[0], size[1] / default[1], size[2] / default[2])


class Dressing:
    """The ``<asset>`` entries and visual geoms of one house (MJCF text, no MuJoCo import).

    Call the geom methods while building the document, then :meth:`assets` for the textures,
    materials and meshes they used (each once).
    """

    def __init__(self) -> None:
        self._textures: dict[tuple[str, str], str] = {}
        self._materials: dict[tuple[str, str, str, float], str] = {}
        self._meshes: dict[tuple[str, Vec], str] = {}

    # ---------------------------------------------------------------- assets
    def _texture(self, file: str, kind: str) -> str:
        key = (file, kind)
        if key not in self._textures:
            self._textures[key] = f"{file.rsplit('.', 1)[0]}_{kind}"
        return self._textures[key]

    def _material(self, file: str | None, kind: str, rgba: RGBA_T, repeat: float = 1.0) -> str:
        """A material for a texture (``None``: plain colour) of a kind (``cube`` or ``2d``)."""
        key = (file or "", kind, _f(*rgba), repeat)
        if key not in self._materials:
            self._materials[key] = f"mat{len(self._materials)}"
        return self._materials[key]

    def _mesh(self, file: str, scale: Vec) -> str:
        key = (file, tuple(round(s, 6) for s in scale))
        if key not in self._meshes:
            self._meshes[key] = f"{file.rsplit('.', 1)[0]}_{len(self._meshes)}"  # type: ignore[index]
        return self._meshes[key]  # type: ignore[index]

    def assets(self) -> list[str]:
        """The ``<asset>`` element of everything the geoms used."""
        materials = []
        for (file, kind, rgba, repeat), name in self._materials.items():
            tex = ""
            if file:
                tex = f'texture="{self._texture(file, kind)}" '
                if kind == "2d":
                    tex += f'texuniform="true" texrepeat="{_f(repeat, repeat)}" '
            materials.append(
                f'<material name="{name}" {tex}rgba="{rgba}" specular="0.15" shininess="0.2"/>'
            )
        textures = [
            f'<texture name="{name}" type="{kind}" file="{ASSET_DIR / "textures" / file}"/>'
            for (file, kind), name in self._textures.items()
        ]
        meshes = [
            f'<mesh name="{name}" file="{ASSET_DIR / "meshes" / file}" scale="{_f(*scale)}"/>'
            for (file, scale), name in self._meshes.items()
        ]
        return ["<asset>", *textures, *materials, *meshes, "</asset>"]

    # ---------------------------------------------------------------- parts
    def _parts(
        self,
        name: str,
        parts: tuple[Part, ...],
        scale: Vec,
        colour: RGBA_T,
        offset: Vec = (0.0, 0.0, 0.0),
        first: int = 0,
    ) -> Iterator[str]:
        """Geoms of a look's parts (numbered from ``first``), scaled per axis about the frame's
        origin, then shifted by ``offset``."""
        sx, sy, sz = scale
        for k, part in enumerate(parts, start=first):
            rgba = colour if part.rgba is None else part.rgba
            if part.mesh is None:
                assert part.box is not None
                (x0, y0, z0), (x1, y1, z1) = part.box
                lo, hi = (x0 * sx, y0 * sy, z0 * sz), (x1 * sx, y1 * sy, z1 * sz)
                mat = self._material(part.texture, "2d", rgba, 4.0)
                centre = tuple((a + b) / 2 + o for a, b, o in zip(lo, hi, offset, strict=True))
                half = tuple((b - a) / 2 for a, b in zip(lo, hi, strict=True))
                yield (
                    f'<geom name="{name}_v{k}" type="box" size="{_f(*half)}" '
                    f'pos="{_f(*centre)}" material="{mat}" {VISUAL}/>'
                )
                continue
            if part.box is not None:
                (x0, y0, z0), (x1, y1, z1) = part.box
                placed = fit(
                    replace(part, box=((x0 * sx, y0 * sy, z0 * sz), (x1 * sx, y1 * sy, z1 * sz)))
                )
                mesh_scale = placed.scale
                pos = placed.pos
            else:  # a generated mesh, made in this frame at the default size
                placed = fit(part)
                mesh_scale, pos = (sx, sy, sz), (0.0, 0.0, 0.0)
            texture = part.texture
            if part.mesh in _FLAT_MESHES and texture in _FLAT_TINT:
                texture, rgba = (
                    None,
                    tuple(  # type: ignore[assignment]
                        a * b for a, b in zip(_FLAT_TINT[texture], rgba, strict=True)
                    ),
                )
            mat = self._material(texture, "cube", rgba)
            mesh = self._mesh(part.mesh, mesh_scale)
            p = tuple(a + o for a, o in zip(pos, offset, strict=True))
            yield (
                f'<geom name="{name}_v{k}" type="mesh" mesh="{mesh}" pos="{_f(*p)}" '
                f'quat="{_f(*placed.quat)}" material="{mat}" {VISUAL}/>'
            )

    def furniture(self, f: Furniture) -> list[str]:
        """Twins of a furniture piece or container carcass (in its body's frame)."""
        look: Look = TRACK1_LOOKS[f.category]
        scale = _ratio(f.size, _FURNITURE_SIZE.get(f.category, f.size))
        return list(self._parts(f"furn_{f.id}", look.parts, scale, RGBA["none"]))

    def lid(self, f: Furniture) -> list[str]:
        """Twins of a container's lid (in the lid body's frame, centred on it)."""
        look = TRACK1_LOOKS[f.category]
        w, d, h = f.size
        dw, dd, dh = _FURNITURE_SIZE.get(f.category, f.size)
        if f.opening == "top":
            scale = (w / dw, d / dd, 1.0)
        else:
            scale = (w / dw, 1.0, h / dh)
        return list(self._parts(f"lid_{f.id}", look.lid, scale, RGBA["none"]))

    def item(self, item: Item) -> list[str]:
        """Twins of an object or tool (centred on its body), in its catalogue colour."""
        look = TRACK1_LOOKS[item.category]
        own = _extent(item.shape, item.size)
        scale = _ratio(own, _ITEM_EXTENT.get(item.category, own))
        return list(self._parts(f"item_{item.id}", look.parts, scale, RGBA[item.colour]))

    def door(self, door: Door) -> list[str]:
        """Twins of a door leaf, its handles and its lamp (in the door body's frame)."""
        w = door.width
        # the leaf as a wood-grained slab (a 2d texture; a cube map streaks on a flat mesh)
        half = (w / 2 - 0.02, 0.026, DOOR_HEIGHT / 2 - 0.01)
        leaf = [
            f'<geom name="door_{door.id}_v0" type="box" size="{_f(*half)}" '
            f'pos="{_f(w / 2, 0, DOOR_HEIGHT / 2 + 0.01)}" '
            f'material="{self._material("wood_dark.png", "2d", (1.0, 1.0, 1.0, 1.0), 1.0)}" '
            f"{VISUAL}/>"
        ]
        parts = TRACK1_LOOKS["door"].parts
        # the handles keep their size and sit by the free edge (w - 0.02), as on a 1 m leaf
        free_edge = (w - 0.02 - DOOR_LEAF_SIZE[0] / 2, 0.0, DOOR_HEIGHT / 2 + 0.01)
        handles = self._parts(
            f"door_{door.id}", parts[1:], (1.0, 1.0, 1.0), RGBA["none"], free_edge, first=1
        )
        return [
            *leaf,
            *handles,
            f'<geom name="doorlamp_{door.id}_v" type="box" size="0.05 0.036 0.05" '
            f'pos="{_f(w - 0.15, 0, 1.1)}" rgba="{LAMP_OFF}" {VISUAL}/>',
        ]

    def floor(self, room_type: str) -> str:
        """The material of a room type's floor."""
        file = FLOORS[room_type]
        return self._material(file, "2d", (1.0, 1.0, 1.0, 1.0), _FLOOR_REPEAT.get(file, 0.5))

    def wall(
        self,
        name: str,
        centre: tuple[float, float],
        half: tuple[float, float],
        z: tuple[float, float],
    ) -> str:
        """A plastered twin of a wall or lintel box, from ``z[0]`` to ``z[1]``."""
        mat = self._material(WALLS[0], "2d", WALL_RGBA, 0.5)
        return (
            f'<geom name="{name}" type="box" size="{_f(*half, (z[1] - z[0]) / 2)}" '
            f'pos="{_f(*centre, (z[0] + z[1]) / 2)}" material="{mat}" {VISUAL}/>'
        )
