"""Where every file of the asset library comes from: wheel, path in it, license, what it shows.

``reproduce.py`` makes each file from this table; the README's table says the same for people,
and a test checks that the two agree.
"""

from __future__ import annotations

from dataclasses import dataclass

from ._meshgen import GENERATED


@dataclass(frozen=True)
class Wheel:
    """A wheel on the package index, pinned by version and hash."""

    package: str
    version: str
    filename: str
    sha256: str


WHEELS: dict[str, Wheel] = {
    w.package: w
    for w in (
        Wheel(
            "robosuite",
            "1.5.2",
            "robosuite-1.5.2-py3-none-any.whl",
            "b9e02df55de8949739de6ba1d196d2ba59cf33c51a76efcfbe5c2f73cdcf99ce",
        ),
        Wheel(
            "metaworld",
            "3.1.1",
            "metaworld-3.1.1-py3-none-any.whl",
            "99e25d9baf97f2f1a19ca89c0d2ca9c6a2b396d9a9be81729de64eedc683f0d3",
        ),
        Wheel(
            "gymnasium-robotics",
            "1.4.2",
            "gymnasium_robotics-1.4.2-py3-none-any.whl",
            "a1743530431cb377e6b3b956d284bc96436fc68bac1648ef205054c178e7dc4b",
        ),
    )
}

_ROBOSUITE = "robosuite/models/assets/"
_KITCHEN = "gymnasium_robotics/envs/assets/kitchen_franka/kitchen_assets/"
_METAWORLD = "metaworld/assets/objects/meshes/"

LICENSE_ROBOSUITE = "LICENSES/robosuite-1.5.2-LICENSE"
LICENSE_METAWORLD = "LICENSES/metaworld-3.1.1-LICENSE"
LICENSE_GYMROB = "LICENSES/gymnasium-robotics-1.4.2-LICENSE"
LICENSE_APACHE = "LICENSES/gymnasium-robotics-1.4.2-assets-LICENSE.md"
NOTICE_KITCHEN = "LICENSES/franka-kitchen-NOTICE"
EAGC_LICENSE = "Apache-2.0 (eagc's own, as pyproject.toml declares)"


@dataclass(frozen=True)
class Source:
    """One file of the library and how ``reproduce.py`` makes it."""

    file: str
    """Path under ``simhost/worlds/assets/``."""
    shows: str
    how: str
    """``copy`` (the wheel's bytes), ``head`` (the wheel file's leading comment), ``texture``
    (decoded, area-resampled to ``TEXTURE_SIZE`` square, PNG) or ``generated`` (_meshgen)."""
    package: str = ""
    member: str = ""
    """Path inside the wheel."""
    license: str = EAGC_LICENSE
    license_files: tuple[str, ...] = ()
    origin: str = "made in code for eagc (simhost/worlds/assets/_meshgen.py)"


TEXTURE_SIZE = 256
"""Every texture is resampled to this many pixels square: plenty for a 224-256 px camera."""

_RS = dict(
    package="robosuite",
    license="MIT",
    license_files=(LICENSE_ROBOSUITE,),
    origin="robosuite's authors (Stanford SVL, UT RPL); the wheel names no other source",
)
_MW = dict(
    package="metaworld",
    license="MIT",
    license_files=(LICENSE_METAWORLD,),
    origin="Meta-World's authors; the wheel names no other source",
)
_GK = dict(
    package="gymnasium-robotics",
    license="Apache-2.0",
    license_files=(LICENSE_APACHE, NOTICE_KITCHEN, LICENSE_GYMROB),
    origin="Google LLC, the Franka kitchen of Relay Policy Learning "
    "(Apache-2.0 header of kitchen_assets/*.xml)",
)

LICENSES: tuple[Source, ...] = (
    Source(
        LICENSE_ROBOSUITE,
        "robosuite's MIT license",
        "copy",
        "robosuite",
        "robosuite-1.5.2.dist-info/licenses/LICENSE",
        "MIT",
        (LICENSE_ROBOSUITE,),
        "robosuite",
    ),
    Source(
        LICENSE_METAWORLD,
        "Meta-World's MIT license",
        "copy",
        "metaworld",
        "metaworld-3.1.1.dist-info/licenses/LICENSE",
        "MIT",
        (LICENSE_METAWORLD,),
        "metaworld",
    ),
    Source(
        LICENSE_GYMROB,
        "Gymnasium-Robotics' MIT license",
        "copy",
        "gymnasium-robotics",
        "gymnasium_robotics-1.4.2.dist-info/licenses/LICENSE",
        "MIT",
        (LICENSE_GYMROB,),
        "gymnasium-robotics",
    ),
    Source(
        LICENSE_APACHE,
        "Gymnasium-Robotics' asset notices with the Apache-2.0 text",
        "copy",
        "gymnasium-robotics",
        "gymnasium_robotics/envs/assets/LICENSE.md",
        "Apache-2.0",
        (LICENSE_APACHE,),
        "gymnasium-robotics",
    ),
    Source(
        NOTICE_KITCHEN,
        "the Franka kitchen's copyright notice (Google LLC, Apache-2.0)",
        "head",
        "gymnasium-robotics",
        _KITCHEN + "kitchen_env_model.xml",
        "Apache-2.0",
        (NOTICE_KITCHEN,),
        "gymnasium-robotics",
    ),
)

TEXTURES: tuple[Source, ...] = (
    Source(
        "textures/floor_wood_planks.png",
        "varnished wood planks (floors)",
        "texture",
        member=_ROBOSUITE + "textures/wood-varnished-panels.png",
        **_RS,
    ),
    Source(
        "textures/floor_tile_grey.png",
        "light grey floor tiles",
        "texture",
        member=_ROBOSUITE + "textures/light-gray-floor-tile.png",
        **_RS,
    ),
    Source(
        "textures/floor_tile_marble.png",
        "large white marble tiles",
        "texture",
        member=_KITCHEN + "textures/white_marble_tile2.png",
        **_GK,
    ),
    Source(
        "textures/floor_tile_mosaic.png",
        "small blue-green mosaic tiles (bathroom)",
        "texture",
        member=_KITCHEN + "textures/tile1.png",
        **_GK,
    ),
    Source(
        "textures/wall_plaster_white.png",
        "white plaster (walls)",
        "texture",
        member=_ROBOSUITE + "textures/white-plaster.png",
        **_RS,
    ),
    Source(
        "textures/wall_plaster_cream.png",
        "cream plaster (walls)",
        "texture",
        member=_ROBOSUITE + "textures/cream-plaster.png",
        **_RS,
    ),
    Source(
        "textures/wood_light.png",
        "light wood grain (furniture)",
        "texture",
        member=_ROBOSUITE + "textures/light-wood.png",
        **_RS,
    ),
    Source(
        "textures/wood_dark.png",
        "dark wood grain (doors, legs)",
        "texture",
        member=_ROBOSUITE + "textures/dark-wood.png",
        **_RS,
    ),
    Source(
        "textures/wood_table.png",
        "orange wood grain (the Track 2 table)",
        "texture",
        member=_KITCHEN + "textures/wood1.png",
        **_GK,
    ),
    Source(
        "textures/marble_counter.png",
        "grey marble (counter tops)",
        "texture",
        member=_KITCHEN + "textures/marble1.png",
        **_GK,
    ),
    Source(
        "textures/fabric_felt.png",
        "grey felt (upholstery, bedding, towels, cloths)",
        "texture",
        member=_ROBOSUITE + "textures/gray-felt.png",
        **_RS,
    ),
    Source(
        "textures/ceramic.png",
        "white glazed ceramic (mugs, plates, bowls, jugs)",
        "texture",
        member=_ROBOSUITE + "textures/ceramic.png",
        **_RS,
    ),
    Source(
        "textures/steel_brushed.png",
        "brushed steel (fridge, bin, blades, bolts)",
        "texture",
        member=_ROBOSUITE + "textures/steel-brushed.png",
        **_RS,
    ),
    Source(
        "textures/brass.png",
        "brass (Track 2 nuts and pegs)",
        "texture",
        member=_ROBOSUITE + "textures/brass-ambra.png",
        **_RS,
    ),
    Source(
        "textures/bread.png",
        "bread crust",
        "texture",
        member=_ROBOSUITE + "textures/bread.png",
        **_RS,
    ),
    Source(
        "textures/glass.png",
        "frosted glass (bottles)",
        "texture",
        member=_ROBOSUITE + "textures/glass.png",
        **_RS,
    ),
    Source(
        "textures/clay.png",
        "terracotta (plant pots)",
        "texture",
        member=_ROBOSUITE + "textures/clay.png",
        **_RS,
    ),
)

COPIED_MESHES: tuple[Source, ...] = (
    Source(
        "meshes/mw_table_top.stl",
        "table top (table, desk)",
        "copy",
        member=_METAWORLD + "table/tabletop.stl",
        **_MW,
    ),
    Source(
        "meshes/mw_table_legs.stl",
        "table legs and rails (table, desk)",
        "copy",
        member=_METAWORLD + "table/tablebody.stl",
        **_MW,
    ),
    Source(
        "meshes/mw_bookcase.stl",
        "bookcase with two shelves (shelf)",
        "copy",
        member=_METAWORLD + "shelf/shelf.stl",
        **_MW,
    ),
    Source(
        "meshes/mw_drawer_case.stl",
        "open box carcass (chest of drawers, desk pedestal)",
        "copy",
        member=_METAWORLD + "drawer/drawercase.stl",
        **_MW,
    ),
    Source(
        "meshes/mw_drawer_handle.stl",
        "drawer pull handle",
        "copy",
        member=_METAWORLD + "drawer/drawerhandle.stl",
        **_MW,
    ),
    Source(
        "meshes/mw_mug.stl", "mug body", "copy", member=_METAWORLD + "coffeemachine/mug.stl", **_MW
    ),
    Source(
        "meshes/mw_mug_handle.stl",
        "mug handle",
        "copy",
        member=_METAWORLD + "coffeemachine/handle.stl",
        **_MW,
    ),
    Source(
        "meshes/gk_cabinet.stl",
        "two-compartment cabinet carcass",
        "copy",
        member=_KITCHEN + "meshes/hingecabinet.stl",
        **_GK,
    ),
    Source(
        "meshes/gk_cabinet_door.stl",
        "cabinet door leaf",
        "copy",
        member=_KITCHEN + "meshes/hingedoor.stl",
        **_GK,
    ),
    Source(
        "meshes/gk_door_handle.stl",
        "vertical bar handle on standoffs (doors, cabinets)",
        "copy",
        member=_KITCHEN + "meshes/hingehandle.stl",
        **_GK,
    ),
    Source(
        "meshes/gk_counter_cabinet.stl",
        "low cabinet with an open bay (counter)",
        "copy",
        member=_KITCHEN + "meshes/slidecabinet.stl",
        **_GK,
    ),
    Source(
        "meshes/gk_bar_handle.stl",
        "long bar handle (fridge, Track 2 drawer)",
        "copy",
        member=_KITCHEN + "meshes/cabinethandle.stl",
        **_GK,
    ),
    Source(
        "meshes/gk_knob.stl",
        "stove knob (Track 2 knob)",
        "copy",
        member=_KITCHEN + "meshes/knob.stl",
        **_GK,
    ),
    Source(
        "meshes/rs_bottle.obj",
        "bottle",
        "copy",
        member=_ROBOSUITE + "objects/meshes/bottle.obj",
        **_RS,
    ),
    Source(
        "meshes/rs_bread.obj",
        "bread loaf",
        "copy",
        member=_ROBOSUITE + "objects/meshes/bread.obj",
        **_RS,
    ),
)

_GENERATED_SHOWS: dict[str, str] = {
    "apple": "apple with a stem",
    "plate": "dinner plate",
    "bowl": "bowl",
    "jug": "jug with a handle and a lip",
    "watering_can": "watering can (spout, rose, handle)",
    "book_cover": "book: covers and spine",
    "book_pages": "book: block of pages",
    "towel": "folded towel",
    "cloth": "rippled cloth",
    "sponge_foam": "sponge: foam layer",
    "sponge_scourer": "sponge: scouring layer",
    "knife_blade": "knife: blade",
    "knife_handle": "knife: handle",
    "scissors_blades": "scissors: blades and pivot",
    "scissors_handles": "scissors: finger rings",
    "plant_pot": "plant: pot",
    "plant_leaves": "plant: leaves",
    "bed_frame": "bed: frame, legs, headboard",
    "bed_mattress": "bed: mattress",
    "bed_pillows": "bed: two pillows",
    "bed_blanket": "bed: blanket",
    "sofa_body": "sofa: base, back, arms, legs",
    "sofa_cushions": "sofa: seat and back cushions",
    "fridge_body": "fridge: cabinet and plinth",
    "fridge_doors": "fridge: fridge and freezer doors",
    "bin_body": "pedal bin: body",
    "bin_lid": "pedal bin: domed lid with a grip",
    "drawer_fronts": "chest of drawers: three drawer fronts",
    "door_leaf": "panelled door leaf",
    "peg_square": "Track 2: square peg (unit)",
    "peg_round": "Track 2: round peg (unit)",
    "peg_hex": "Track 2: hexagonal peg (unit)",
    "hex_nut": "Track 2: hex nut (unit)",
    "bolt": "Track 2: threaded bolt (unit)",
}

GENERATED_MESHES: tuple[Source, ...] = tuple(
    Source(
        f"meshes/{name}.obj",
        _GENERATED_SHOWS[name],
        "generated",
        member=f"_meshgen.{make.__name__}",
    )
    for name, make in GENERATED.items()
)

SOURCES: tuple[Source, ...] = LICENSES + TEXTURES + COPIED_MESHES + GENERATED_MESHES
"""Every file of the library (besides this code and the README), in the order it is made."""
