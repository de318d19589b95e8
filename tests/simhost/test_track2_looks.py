"""Track 2 benches a vision model can see (issue 24): textured table and parts from the asset
library, visual-only geoms, the official image size, and the one-pass render."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from simhost.worlds.track2 import FAMILIES, OFFICIAL_IMAGE_SIZE, BenchEnv
from simhost.worlds.track2._bench import HIDDEN_GROUP, RAY_GROUPS, VISUAL_GROUP

MESHES = {"insertion": "peg_look", "rotation": None, "opening": None, "assembly": None,
          "tool_use": None}


@pytest.mark.parametrize("family", FAMILIES)
def test_official_frame_is_textured_at_the_official_size(family: str) -> None:
    env = BenchEnv(family=family, instance_seed=60500, split="standard")
    try:
        obs, _ = env.reset(seed=3)
        m = env.model
        assert obs["rgb"].shape == (*OFFICIAL_IMAGE_SIZE, 3)
        assert obs["depth"].shape == OFFICIAL_IMAGE_SIZE
        assert m.ntex >= 5 and m.nmat >= 5  # the table's wood and the parts' materials
        table = m.geom("table").id
        assert m.tex_type[m.mat_texid[m.geom_matid[table]][1]] == mujoco.mjtTexture.mjTEXTURE_2D
        # a flat-shaded table is one colour per row; the wood grain varies along a row
        rgb = obs["rgb"].astype(float)
        row = rgb[-4, :, :]
        assert row.std(axis=0).max() > 4.0
        # what the camera sees of the parts carries materials (but paint marks, a button)
        shown = (m.geom_group != HIDDEN_GROUP) & (m.geom_bodyid > 0)
        assert (m.geom_matid[shown] >= 0).mean() > 0.8
        assert (m.geom_group == VISUAL_GROUP).sum() >= 2  # the gripper's wrist at least
    finally:
        env.close()


def test_parts_are_asset_meshes() -> None:
    names = set()
    for family, seed in (("insertion", 60501), ("rotation", 60502), ("rotation", 60503),
                         ("rotation", 60504), ("rotation", 60505)):
        env = BenchEnv(family=family, instance_seed=seed, split="standard")
        m = env.model
        names |= {m.mesh(i).name for i in range(m.nmesh)}
        env.close()
    assert "peg_look" in names
    assert names & {"nut_look", "knob_look"}


@pytest.mark.parametrize("family", FAMILIES)
def test_visual_geoms_touch_no_physics(family: str) -> None:
    env = BenchEnv(family=family, instance_seed=60510, split="challenge")
    try:
        m = env.model
        vis = np.nonzero(m.geom_group == VISUAL_GROUP)[0]
        assert len(vis) > 0
        assert not m.geom_contype[vis].any() and not m.geom_conaffinity[vis].any()
        # massless: the bodies' mass equals the sum of their non-visual geoms' masses
        assert not np.any(m.geom_group[(m.geom_contype + m.geom_conaffinity) > 0]
                          == VISUAL_GROUP)
        # no ray sees a visual geom: a ray straight down onto the wrist hits the palm
        d = env.data
        env.reset(seed=0)
        hand = m.body("hand").id
        start = d.xpos[hand] + np.array([0.0, 0.0, 0.3])
        geomid = np.zeros(1, dtype=np.int32)
        mujoco.mj_ray(m, d, start, np.array([0.0, 0.0, -1.0]), RAY_GROUPS, 1, -1, geomid)
        assert m.geom_group[geomid[0]] != VISUAL_GROUP
        assert int(geomid[0]) == m.geom("palm").id
        mujoco.mj_ray(m, d, start, np.array([0.0, 0.0, -1.0]), None, 1, -1, geomid)
        assert m.geom_group[geomid[0]] == VISUAL_GROUP  # without the mask it would
    finally:
        env.close()


def test_visual_geoms_carry_no_mass() -> None:
    env = BenchEnv(family="insertion", instance_seed=60520, split="standard")
    try:
        m = env.model
        peg = m.body("peg").id
        own = np.nonzero(m.geom_bodyid == peg)[0]
        assert {int(m.geom_group[g]) for g in own} == {VISUAL_GROUP, HIDDEN_GROUP}
        # the peg's mass is its collision geom's alone (density x volume of the primitive)
        spec = mujoco.MjSpec.from_string(env.xml)
        for g in spec.body("peg").geoms:
            if g.group == VISUAL_GROUP:
                spec.delete(g)
        bare = spec.compile()
        assert bare.body_mass[peg] == m.body_mass[peg]
        assert np.array_equal(bare.body_inertia[peg], m.body_inertia[peg])
    finally:
        env.close()


def test_one_pass_render_matches_mujoco_renderer() -> None:
    """RGB and depth from one pass into an image-sized buffer equal mujoco.Renderer's two
    passes into a 640x480 buffer, bit for bit."""
    env = BenchEnv(family="opening", instance_seed=60530, split="standard")
    try:
        obs, _ = env.reset(seed=5)
        rng = np.random.default_rng(0)
        for _ in range(6):
            obs, *_ = env.step(rng.uniform(-1, 1, 5))
        env.model.vis.global_.offwidth, env.model.vis.global_.offheight = 640, 480
        h, w = env.image_size
        with mujoco.Renderer(env.model, h, w) as r:
            r.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
            r.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
            r.update_scene(env.data, camera="overview")
            rgb = r.render()
            r.enable_depth_rendering()
            r.update_scene(env.data, camera="overview")
            depth = r.render()
        fresh, fresh_depth, _ = env._render(depth=True)
        assert np.array_equal(fresh, rgb)
        assert np.array_equal(fresh_depth, depth)
    finally:
        env.close()

