"""Track 2's two cameras show the bench (issue 36): every present part at reset in view of a
camera, unhidden by the gripper, measured in pixels from the segmentation at the official
image size; the parts rows' occlusion rule follows both cameras."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from simhost.worlds.track2 import FAMILIES, OFFICIAL_IMAGE_SIZE, BenchEnv, split_config
from simhost.worlds.track2._bench import CAMERA_FOVY, CAMERAS, HOME, PALM_BOTTOM

SEEDS = (0, 1, 2)
MIN_PIXELS = 150
ACROSS = 30
"""The issue's bar: 30 px across (the larger side of the part's box in the image)."""
FLOOR = 12
"""No part is smaller than this across in its best view. At 256x192 a camera that frames its
half of the bench (0.3-0.4 m by 0.38 m) draws 4-6 px per cm, so a part about 3 cm across
(a small nut, the smallest assembly blocks, the puck) comes out at 16-29 px (the smallest
here: challenge seed 0's nut, 2.9 cm across its corners at the far edge of the front camera's
band, 16 px and 158 px)."""


def _sizes(family: str, seed: int, split: str) -> list[tuple[str, int, int]]:
    """(part, pixels, px across) of every present part at reset, in the camera that shows it
    best (most pixels)."""
    cfg = split_config(split).bench
    cfg = cfg.model_copy(update={"observation": cfg.observation.model_copy(
        update={"segmentation": True})})
    env = BenchEnv(family=family, instance_seed=seed, split=split, config=cfg)
    try:
        obs, _ = env.reset(seed=seed)
        segs = [obs["segmentation"], obs["segmentation_front"]]
        assert all(s.shape == OFFICIAL_IMAGE_SIZE for s in segs)
        rows = env.task.parts()
        out = []
        for i, ref in enumerate(env.task.row_refs()):
            if ref is None or ref[0] != "body" or rows[i, 0] < 0.5:
                continue  # padding rows and the tools' tips (a site, no pixels of its own)
            if family == "tool_use" and i == 4 and env.task.press:
                continue  # the button at the bottom of its well (below)
            best = (0, 0)
            for seg in segs:
                ys, xs = np.nonzero(seg == i + 1)
                if len(xs):
                    across = max(int(xs.max() - xs.min()) + 1, int(ys.max() - ys.min()) + 1)
                    best = max(best, (len(xs), across))
            out.append((env.task.part_names[i], *best))
        return out
    finally:
        env.close()


@pytest.mark.parametrize("split", ["standard", "challenge"])
def test_every_part_is_in_view_at_reset(split: str) -> None:
    """Every present part shows at least 150 px in one camera, none under ``FLOOR`` across,
    and three in four at ``ACROSS`` or more (here 30 of 34 on ``standard``, 28 of 36 on
    ``challenge``; the old single overview camera: 12 of 60 parts on seeds 0-4 of
    ``standard``). The press button is left out: it sits 3-7 cm down a well 2.2 cm wide,
    narrower than the fingers on purpose, and shows only from straight above."""
    sizes = [(f"{family} {seed} {name}", px, across) for family in FAMILIES for seed in SEEDS
             for name, px, across in _sizes(family, seed, split)]
    small = [s for s in sizes if s[1] < MIN_PIXELS or s[2] < FLOOR]
    assert not small, small
    wide = sum(across >= ACROSS for _, _, across in sizes)
    assert wide >= 0.75 * len(sizes), [s for s in sizes if s[2] < ACROSS]


def test_nothing_is_hidden_by_the_gripper_at_reset() -> None:
    """At ``HOME`` the gripper hides no part from both cameras (the old overview camera looked
    over the gripper at the hole, the knob and the well)."""
    for split in ("standard", "challenge"):
        for family in FAMILIES:
            for seed in SEEDS:
                env = BenchEnv(family=family, instance_seed=seed, split=split,
                               render_rgbd=False)
                env.reset(seed=seed)
                assert not env.channel._occluded(env.task.parts()).any(), (split, family, seed)
                env.close()


def test_cameras_frame_their_bands() -> None:
    """The rule of ``CAMERAS``: each camera's image holds its band of the table, from the top
    up to 8 cm, and shows the table (no sky) at every corner of the other band's near edge."""
    env = BenchEnv(family="insertion", instance_seed=0, split="standard", render_rgbd=False)
    env.reset(seed=0)
    m, d = env.model, env.data
    h, w = OFFICIAL_IMAGE_SIZE
    bands = {"overview": (-0.24, 0.06), "front": (0.06, 0.46)}
    f = h / 2 / math.tan(math.radians(CAMERA_FOVY) / 2)
    for cam in CAMERAS:
        c = m.camera(cam).id
        pos, mat = d.cam_xpos[c], d.cam_xmat[c].reshape(3, 3)
        assert m.cam_fovy[c] == CAMERA_FOVY
        # the optical axis (the camera's -z) 60 degrees below the horizon
        assert abs(-mat[2, 2] + math.sin(math.radians(60))) < 1e-4
        x0, x1 = bands[cam]
        for x in (x0, x1):
            for y in (-0.19, 0.19):
                for z in (0.0, 0.08):
                    local = mat.T @ (np.array([x, y, z]) - pos)
                    assert local[2] < 0  # in front of the camera
                    u = w / 2 + f * local[0] / -local[2]
                    v = h / 2 - f * local[1] / -local[2]
                    assert 0 <= u <= w and 0 <= v <= h, (cam, x, y, z, u, v)
    env.close()


def _hand_at(env: BenchEnv, xyz: np.ndarray, yaw: float = 0.0) -> None:
    """Put the gripper's TCP at ``xyz`` (fingers open), as a state, not by stepping."""
    adr = env.sim._qadr
    env.data.qpos[adr[:4]] = (*xyz, yaw)
    env.data.qpos[adr[4:]] = 0.04
    mujoco.mj_forward(env.model, env.data)


def test_a_part_is_hidden_only_when_the_gripper_hides_it_from_both_cameras() -> None:
    env = BenchEnv(family="insertion", instance_seed=0, split="standard", render_rgbd=False)
    try:
        env.reset(seed=0)
        ch = env.channel
        over, front = ch._cams
        truth = env.task.parts()
        peg = truth[0, 1:4].copy()
        rows = np.array([True, False])
        # the palm on the overview camera's line of sight to the peg, 12 cm above it
        cam = env.data.cam_xpos[over]
        palm_z = peg[2] + 0.12
        t = (palm_z - peg[2]) / (cam[2] - peg[2])
        at = peg + t * (cam - peg)
        _hand_at(env, np.array([at[0], at[1], palm_z - PALM_BOTTOM - 0.012]))
        assert ch._occluded_from(truth, over, rows)[0]
        assert not ch._occluded_from(truth, front, rows)[0]
        assert not ch._occluded(truth)[0]  # the front camera sees it: measured
        # the hand turned across the cameras' view, its palm just above the peg's top:
        # hidden from both, the row keeps its last value
        top = peg[2] + env.task.h / 2
        _hand_at(env, np.array([peg[0], peg[1], top + 0.004 - PALM_BOTTOM]), math.pi / 2)
        assert ch._occluded(truth)[0]
        # along them (fingers either side of the peg, seen between them): measured
        _hand_at(env, np.array([peg[0], peg[1], top + 0.004 - PALM_BOTTOM]))
        assert not ch._occluded(truth)[0]
        _hand_at(env, HOME[:3])
        assert not ch._occluded(truth).any()
    finally:
        env.close()
