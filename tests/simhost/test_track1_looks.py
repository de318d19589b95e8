"""Track 1's dressed house: what the camera draws, and that the simulation did not change.

The camera draws only the visual group (textured floors, plastered walls, the asset
library's meshes); the primitives that decide collisions and rays stay as they were, and the
optimized step and render give the same states and images as the plain MuJoCo path.
"""

from __future__ import annotations

import math
import re

import mujoco
import numpy as np
import pytest

from simhost.worlds.track1 import HouseEnv, generate_house, house_split, make_action
from simhost.worlds.track1._dress import VISUAL_GROUP
from simhost.worlds.track1._mjcf import build_mjcf
from simhost.worlds.track1._sim import _RAY_GROUPS, _SCAN_GROUPS, HouseSim

SEED = 20017
_TWIN = re.compile(r'<geom name="(?:\w+_v\d*|wallvis_\d+|lintelvis_\d+)"[^>]*/>')


def _official_env() -> HouseEnv:
    env = HouseEnv(split="standard")
    env.reset(seed=SEED)
    return env


def test_official_frame_is_textured_assets_not_flat_primitives() -> None:
    env = _official_env()
    assert env.config.image_size == (256, 192)
    obs, _ = env.reset(seed=SEED)
    rgb, seg = obs["rgb"], obs["segmentation"]
    assert rgb.shape == (192, 256, 3) and seg.shape == (192, 256)
    sim = env.unwrapped._house().sim  # type: ignore[attr-defined]
    m = sim.model
    names = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_MESH, k) for k in range(m.nmesh)}
    textures = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TEXTURE, k) for k in range(m.ntex)}
    assert any(n.startswith("door_handle") or n.startswith("gk_") for n in names), names
    assert {"wall_plaster_white_2d"} <= textures and len(textures) >= 5
    # a flat-shaded primitive fills a face with one colour: textured surfaces vary within
    # one instance's pixels and within the floor
    floor = (seg == -1) & (obs["depth"] < 20)
    assert floor.sum() > 100
    assert rgb[floor].astype(float).std(axis=0).max() > 6.0
    # only the visual group is drawn, and every drawn geom is visual only
    drawn = m.geom_group == VISUAL_GROUP
    assert drawn.sum() > 50
    assert not m.geom_contype[drawn].any() and not m.geom_conaffinity[drawn].any()
    env.close()


def test_segmentation_names_the_instance_of_what_is_drawn() -> None:
    env = _official_env()
    house = env.unwrapped._house()  # type: ignore[attr-defined]
    layout, sim = house.layout, house.sim
    ids = {e.id for e in (*layout.doors, *layout.furniture, *layout.items)}
    seen: set[int] = set()
    for f in layout.furniture[:6]:
        c, s = math.cos(f.yaw), math.sin(f.yaw)
        d = f.size[1] / 2 + 1.0
        sim.set_robot_pose(f.pos[0] - s * d, f.pos[1] + c * d, f.yaw - math.pi / 2)
        sim.forward()
        _, _, seg = sim.render_rgbd(256, 192)
        assert (seg == f.id).mean() > 0.05, f.category
        seen |= set(np.unique(seg).tolist()) - {-1}
    assert seen <= ids
    env.close()


def _undressed(xml: str) -> str:
    """The house's MJCF without its visual twins and assets (what the simulation used to be)."""
    xml = re.sub(r"<asset>.*?</asset>", "", _TWIN.sub("", xml), flags=re.S)
    return re.sub(r'material="[^"]*"', 'rgba="0.5 0.5 0.5 1"', xml)


def test_twins_change_no_mass_contact_or_ray() -> None:
    split = house_split("standard")
    layout = generate_house(SEED, params=split.params)
    xml = build_mjcf(layout)
    plain_xml = _undressed(xml)
    dressed = mujoco.MjModel.from_xml_string(xml)
    plain = mujoco.MjModel.from_xml_string(plain_xml)
    assert dressed.ngeom > plain.ngeom
    for field in ("body_mass", "body_inertia", "body_ipos", "body_iquat", "dof_M0"):
        assert np.array_equal(getattr(dressed, field), getattr(plain, field)), field
    dd, dp = mujoco.MjData(dressed), mujoco.MjData(plain)
    mujoco.mj_forward(dressed, dd)
    mujoco.mj_forward(plain, dp)
    rng = np.random.default_rng(0)
    width, height = layout.extent
    hit_d, hit_p = np.array([-1], np.int32), np.array([-1], np.int32)
    for _ in range(400):
        start = np.array([rng.uniform(0, width), rng.uniform(0, height), rng.uniform(0.1, 1.5)])
        vec = rng.normal(size=3)
        vec /= np.linalg.norm(vec)
        for groups in (_RAY_GROUPS, _SCAN_GROUPS):
            a = mujoco.mj_ray(dressed, dd, start, vec, groups, 1, -1, hit_d)
            b = mujoco.mj_ray(plain, dp, start, vec, groups, 1, -1, hit_p)
            assert a == b
            name = mujoco.mjtObj.mjOBJ_GEOM
            assert mujoco.mj_id2name(dressed, name, int(hit_d[0])) == mujoco.mj_id2name(
                plain, name, int(hit_p[0])
            )


def _reference_step(sim: HouseSim, held: int) -> bool:
    """The unoptimized step: ``mj_step``, carry the held item, ``mj_fwdPosition``."""
    mujoco.mj_step(sim.model, sim.data)
    if held >= 0:
        k = sim.mocap[held]
        sim.data.mocap_pos[k], sim.data.mocap_quat[k] = sim.hand_pose()
    mujoco.mj_fwdPosition(sim.model, sim.data)
    return sim.robot_in_contact()


def _reference_render(sim: HouseSim, w: int, h: int) -> tuple[np.ndarray, ...]:
    """The renderer's own three passes (RGB, depth, segmentation)."""
    r = sim._renderer  # noqa: SLF001
    assert r is not None
    r.update_scene(sim.data, camera="eye", scene_option=sim._scene_option)  # noqa: SLF001
    rgb = r.render().copy()
    r.enable_depth_rendering()
    depth = r.render().astype(np.float32)
    r.disable_depth_rendering()
    r.enable_segmentation_rendering()
    seg = r.render()
    r.disable_segmentation_rendering()
    ids = np.full(seg.shape[:2], -1, dtype=np.int32)
    is_geom = (seg[:, :, 1] == int(mujoco.mjtObj.mjOBJ_GEOM)) & (seg[:, :, 0] >= 0)
    ids[is_geom] = sim.geom_instance[seg[:, :, 0][is_geom]]
    return rgb, depth, ids


def _episode(
    reference: bool, split: str = "standard", size: tuple[int, int] = (128, 96)
) -> list[tuple[np.ndarray, ...]]:
    """24 steps of moves and object actions; per step the state, then the observation's
    images (the reference: the renderer's own passes) and its other channels."""
    w, h = size
    env = HouseEnv(split=split, image_size=size)
    obs, _ = env.reset(seed=SEED)
    house = env.unwrapped._house()  # type: ignore[attr-defined]
    sim = house.sim
    if reference:
        sim.step = lambda held: _reference_step(sim, held)  # type: ignore[method-assign]
    out = []
    rng = np.random.default_rng(3)
    for k in range(24):
        dets = [int(i) for i, m in zip(obs["det_id"], obs["det_mask"], strict=True) if m]
        if k % 4 == 3 and dets:
            prim = ("open", "pick", "close", "place")[(k // 4) % 4]
            action = make_action(prim, target=dets[k % len(dets)])
        else:
            action = make_action(
                "move", forward=float(rng.uniform(-0.3, 1)), turn=float(rng.uniform(-1, 1))
            )
        obs, *_ = env.step(action)
        images = (
            _reference_render(sim, w, h)
            if reference
            else (obs["rgb"], obs["depth"], obs["segmentation"])
        )
        rest = tuple(obs[key] for key in sorted(obs) if key not in ("rgb", "depth", "segmentation"))
        out.append((sim.get_physics(), sim.data.qpos.copy(), sim.data.geom_xpos.copy(), *images,
                    *rest))
    env.close()
    return out


@pytest.mark.parametrize(
    ("split", "size"),
    [("standard", (128, 96)), ("challenge", (256, 192)), ("standard", (160, 48))],
)
def test_optimized_step_and_render_match_the_plain_path(split: str, size: tuple[int, int]) -> None:
    ours = _episode(False, split, size)
    ref = _episode(True, split, size)
    for k, (a, b) in enumerate(zip(ours, ref, strict=True)):
        for x, y in zip(a[:3], b[:3], strict=True):
            assert np.array_equal(x, y), f"state differs at step {k}"
        rgb, depth, seg = b[3:6]
        assert np.array_equal(a[3], rgb), f"rgb differs at step {k}"
        assert np.array_equal(a[4], np.minimum(depth, np.float32(100.0))), k
        assert np.array_equal(a[5], seg), f"segmentation differs at step {k}"
        for x, y in zip(a[6:], b[6:], strict=True):
            assert np.array_equal(x, y), f"an observation channel differs at step {k}"


def test_culling_leaves_out_geoms_the_camera_cannot_see() -> None:
    """The render skips scene geoms out of view (so the identity test above covers them)
    and keeps every geom that gives a pixel."""
    env = _official_env()
    sim = env.unwrapped._house().sim  # type: ignore[attr-defined]
    r = sim._renderer  # noqa: SLF001
    assert r is not None
    r.update_scene(sim.data, camera="eye", scene_option=sim._scene_option)  # noqa: SLF001
    culled = sim._cull(r.scene, 256 / 192)  # noqa: SLF001
    assert 0 < len(culled) < r.scene.ngeom
    seen = set(np.unique(env.observe()[0]["segmentation"]).tolist()) - {-1}
    culled_instances = {int(sim.geom_instance[r.scene.geoms[k].objid]) for k in culled}
    drawn = {int(sim.geom_instance[r.scene.geoms[k].objid])
             for k in range(r.scene.ngeom) if k not in set(culled)}
    assert seen <= drawn
    assert culled_instances - seen, "some culled entity is out of view entirely"
    env.close()
