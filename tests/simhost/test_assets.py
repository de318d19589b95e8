"""The asset library: every mesh and texture loads in MuJoCo as a visual-only geom and renders
(EGL) a frame that is not flat; every file is in the README, in SHA256SUMS and has a license;
every catalogue category and colour maps to assets."""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path

import mujoco
import numpy as np
import pytest

from simhost.worlds.assets import (
    ASSET_DIR,
    FLOORS,
    SOURCES,
    TRACK1_LOOKS,
    TRACK2_LOOKS,
    WALLS,
    Part,
    fit,
)
from simhost.worlds.assets._meshgen import GENERATED, obj_text
from simhost.worlds.assets.reproduce import decode_png, encode_png, read_sums, resample
from simhost.worlds.track1._catalogue import (
    CATEGORIES,
    DEFAULT_FURNITURE,
    DEFAULT_ITEMS,
    RGBA,
    ROOM_TYPES,
    ItemSpec,
)
from simhost.worlds.track1._layout import CARCASS

VISUAL = 'contype="0" conaffinity="0" density="0" group="4"'
"""Visual only: no contact, no mass, a group Track 1's rays (groups 0-2) never see."""
RAY_GROUPS = np.array([1, 1, 1, 0, 0, 0], np.uint8)
SIZE = 96

MESHES = sorted(p.name for p in (ASSET_DIR / "meshes").iterdir())
TEXTURES = sorted(p.name for p in (ASSET_DIR / "textures").iterdir())


def _render(xml: str, lookat: tuple[float, float, float], distance: float) -> np.ndarray:
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    camera = mujoco.MjvCamera()
    camera.lookat[:] = lookat
    camera.distance, camera.azimuth, camera.elevation = distance, 120.0, -30.0
    option = mujoco.MjvOption()
    option.geomgroup[:] = 1
    with mujoco.Renderer(model, SIZE, SIZE) as renderer:
        renderer.update_scene(data, camera, option)
        return renderer.render().copy()


def _scene(assets: str, geoms: str) -> str:
    folders = f'meshdir="{ASSET_DIR / "meshes"}" texturedir="{ASSET_DIR / "textures"}"'
    return f"""<mujoco><compiler {folders}/>
<visual><global offwidth="{SIZE}" offheight="{SIZE}"/></visual>
<asset>{assets}</asset>
<worldbody><light pos="0 0 4" dir="0 0 -1" directional="true"/>{geoms}</worldbody></mujoco>"""


@pytest.mark.parametrize("name", MESHES)
def test_mesh_loads_as_visual_geom_and_renders(name: str) -> None:
    xml = _scene(
        f'<mesh name="m" file="{name}"/>',
        f'<body name="b"><geom type="mesh" mesh="m" rgba="0.8 0.6 0.4 1" {VISUAL}/></body>',
    )
    model = mujoco.MjModel.from_xml_string(xml)
    assert model.ngeom == 1 and model.nmesh == 1 and model.mesh_facenum[0] > 0
    assert model.body_mass[1] == 0.0 and model.geom_contype[0] == model.geom_conaffinity[0] == 0
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    centre = data.geom_xpos[0]
    # a ray from above through the mesh misses it when it looks only at Track 1's ray groups
    hit = np.array([-1], np.int32)
    start = centre + np.array([0.0, 0.0, 5.0])
    assert mujoco.mj_ray(model, data, start, np.array([0, 0, -1.0]), RAY_GROUPS, 1, -1, hit) < 0
    frame = _render(xml, tuple(centre), 3.0 * float(model.geom_rbound[0]))
    assert (frame.reshape(-1, 3).std(axis=0) > 5).any(), f"{name} renders a flat frame"


@pytest.mark.parametrize("name", TEXTURES)
def test_texture_loads_and_is_not_flat(name: str) -> None:
    xml = _scene(
        f'<texture name="t" type="2d" file="{name}"/><material name="m" texture="t"/>',
        f'<geom type="box" size="1 1 0.01" material="m" {VISUAL}/>',
    )
    model = mujoco.MjModel.from_xml_string(xml)
    assert (model.tex_width[0], model.tex_height[0]) == (256, 256)
    texels = decode_png((ASSET_DIR / "textures" / name).read_bytes()).astype(float)
    assert texels.std() > 2.0, f"{name} is a flat colour"
    frame = _render(xml, (0.0, 0.0, 0.0), 1.2).astype(float)
    # the frame is all texture: its variation is the texture's, not a flat-shaded plane
    assert frame.reshape(-1, 3).std(axis=0).max() > 1.5


def _lid_position(category: str) -> tuple[float, float, float]:
    """Where Track 1 puts a container's closed lid (``lid_pose``), in the container's frame."""
    spec = next(f for f in DEFAULT_FURNITURE if f.category == category)
    w, d, h = spec.size
    if spec.opening == "top":
        return (0.0, 0.0, h + CARCASS / 2)
    return (0.0, d / 2 - CARCASS / 2, h / 2)


def _look_scene(category: str, colour: str) -> str:
    look = TRACK1_LOOKS[category]
    assets, geoms = [], []
    for k, part in enumerate(look.parts + look.lid):
        rgba = RGBA[colour] if part.rgba is None else part.rgba
        material = ""
        if part.texture:
            kind = "2d" if part.mesh is None else "cube"
            assets.append(f'<texture name="t{k}" type="{kind}" file="{part.texture}"/>')
            assets.append(
                f'<material name="m{k}" texture="t{k}" rgba="{" ".join(map(str, rgba))}"/>'
            )
            material = f'material="m{k}"'
        else:
            material = f'rgba="{" ".join(map(str, rgba))}"'
        lift = _lid_position(category) if part in look.lid else (0.0, 0.0, 0.0)
        if part.mesh is None:
            assert part.box is not None
            lo, hi = np.array(part.box[0]), np.array(part.box[1])
            pos = " ".join(map(str, (lo + hi) / 2 + lift))
            geoms.append(
                f'<geom type="box" size="{" ".join(map(str, (hi - lo) / 2))}" pos="{pos}" '
                f"{material} {VISUAL}/>"
            )
            continue
        placed = fit(part)
        assets.append(
            f'<mesh name="g{k}" file="{part.mesh}" scale="{" ".join(map(str, placed.scale))}"/>'
        )
        pos = " ".join(map(str, np.array(placed.pos) + lift))
        geoms.append(
            f'<geom type="mesh" mesh="g{k}" pos="{pos}" quat="{" ".join(map(str, placed.quat))}" '
            f"{material} {VISUAL}/>"
        )
    return _scene("".join(assets), "".join(geoms))


def _looks_to_render() -> list[tuple[str, str]]:
    colours = {spec.category: spec.colours for spec in DEFAULT_ITEMS}
    return [(c, colour) for c in CATEGORIES for colour in colours.get(c, ("none",))]


@pytest.mark.parametrize(("category", "colour"), _looks_to_render())
def test_every_category_and_colour_has_a_look_that_renders(category: str, colour: str) -> None:
    xml = _look_scene(category, colour)
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lo = np.min(data.geom_xpos - model.geom_rbound[:, None], axis=0)
    hi = np.max(data.geom_xpos + model.geom_rbound[:, None], axis=0)
    frame = _render(xml, tuple((lo + hi) / 2), 1.1 * float(np.max(hi - lo)))
    assert (frame.reshape(-1, 3).std(axis=0) > 5).any()
    if os.environ.get("EAGC_ASSET_FRAMES"):  # a folder: keep the frames to look at
        from simhost.host._png import write_png

        write_png(
            Path(os.environ["EAGC_ASSET_FRAMES"]) / f"{category}_{colour}.png",
            _render(xml, tuple((lo + hi) / 2), 1.1 * float(np.max(hi - lo))),
        )


@pytest.mark.parametrize(
    "spec", [s for s in DEFAULT_ITEMS if len(s.colours) > 1], ids=lambda s: s.category
)
def test_colour_changes_only_the_colour(spec: ItemSpec) -> None:
    """Two colours of one category: the same silhouette, other pixels (look-alikes alike)."""
    frames = []
    for colour in spec.colours[:2]:
        xml = _look_scene(spec.category, colour)
        frames.append(_render(xml, (0.0, 0.0, 0.0), 0.5).astype(int))
    masks = [f.max(axis=2) > 0 for f in frames]
    assert (masks[0] != masks[1]).mean() < 0.01  # edge pixels dark enough to read as background
    assert np.abs(frames[0] - frames[1]).max() > 40


def test_looks_cover_the_catalogue_and_name_real_files() -> None:
    assert set(TRACK1_LOOKS) == set(CATEGORIES)
    assert set(FLOORS) == set(ROOM_TYPES)
    parts: list[Part] = [p for look in TRACK1_LOOKS.values() for p in look.parts + look.lid]
    parts += list(TRACK2_LOOKS.values())
    for part in parts:
        assert part.mesh is None or part.mesh in MESHES, part
        assert part.texture is None or part.texture in TEXTURES, part
        if part.mesh is None and part in TRACK2_LOOKS.values():
            continue
        if part.mesh is None:
            assert part.box is not None
    for name in (*FLOORS.values(), *WALLS):
        assert name in TEXTURES


def test_every_file_is_listed_licensed_and_hashed() -> None:
    readme = (ASSET_DIR / "README.md").read_text()
    listed = set(re.findall(r"`((?:textures|meshes|LICENSES)/[^`]+)`", readme))
    on_disk = {
        str(p.relative_to(ASSET_DIR))
        for d in ("textures", "meshes", "LICENSES")
        for p in (ASSET_DIR / d).iterdir()
    }
    by_file = {s.file: s for s in SOURCES}
    assert on_disk == set(by_file), "a file without a source, or a source without its file"
    assert on_disk <= listed, f"not in the README's table: {sorted(on_disk - listed)}"
    sums = read_sums()
    assert set(sums) == on_disk
    for name in sorted(on_disk):
        data = (ASSET_DIR / name).read_bytes()
        assert hashlib.sha256(data).hexdigest() == sums[name], f"{name} differs from SHA256SUMS"
        source = by_file[name]
        assert source.license, name
        for license_file in source.license_files:
            assert (ASSET_DIR / license_file).is_file(), (name, license_file)
        if source.how != "generated":
            assert source.package and source.member and source.license_files, name


def test_generated_meshes_are_made_again_byte_for_byte() -> None:
    for name, make in GENERATED.items():
        made = obj_text(name, make()).encode()
        assert made == (ASSET_DIR / "meshes" / f"{name}.obj").read_bytes(), name


def test_texture_pipeline_is_exact() -> None:
    rng = np.random.default_rng(7)
    image = rng.integers(0, 256, (50, 70, 3), dtype=np.uint8)
    assert np.array_equal(decode_png(encode_png(image)), image)
    flat = np.full((33, 45, 3), 200, np.uint8)
    assert (resample(flat, 16) == 200).all()
    blocks = np.kron(rng.integers(0, 256, (4, 4, 3)), np.ones((3, 3, 1))).astype(np.uint8)
    assert np.array_equal(resample(blocks, 4), blocks[::3, ::3])
