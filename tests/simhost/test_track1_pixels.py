"""``HouseEnv`` on the ``vision`` split: the standard split's world and camera without a
detector, and actions by pixel resolved through the segmentation the env keeps."""

from __future__ import annotations

import numpy as np
import pytest

from simhost.worlds.track1 import (
    REASONS,
    HouseEnv,
    house_split,
    make_action,
    make_pixel_action,
    parse_pixel_action,
)

SEED = 20101


def _reason(info: dict) -> str:
    return str(info["action_result"]["reason"])


def test_vision_observes_the_standard_world_without_detections_or_segmentation() -> None:
    vision, standard = HouseEnv(split="vision"), HouseEnv(split="standard")
    try:
        obs_v, info_v = vision.reset(seed=SEED)
        obs_s, _ = standard.reset(seed=SEED)
        assert vision.layout.digest() == standard.layout.digest()
        assert set(obs_v) == set(vision.observation_space.spaces)
        assert not {k for k in obs_v if k.startswith("det_")} and "segmentation" not in obs_v
        assert {"rgb", "depth", "odometry", "range_scan", "room", "room_type"} <= set(obs_v)
        assert info_v["detections"] == []
        detected = 0
        for k in range(4):  # the same moves: the same pixels, pose and scan as standard
            obs_v, _, _, _, info_v = vision.step(make_pixel_action("move", turn=0.5,
                                                                   forward=0.3))
            obs_s, _, _, _, info_s = standard.step(make_action("move", turn=0.5, forward=0.3))
            for key in ("rgb", "depth", "odometry", "range_scan", "room"):
                assert np.array_equal(obs_v[key], obs_s[key]), (k, key)
            assert info_v["detections"] == []
            detected += len(info_s["detections"])
            kept = vision.last_segmentation()
            assert kept is not None and np.array_equal(kept, obs_s["segmentation"])
            assert vision.frame_instances() == {int(i) for i in np.unique(kept) if i >= 0}
        assert detected, "standard's detector saw nothing: pick another seed"
    finally:
        vision.close()
        standard.close()


def test_pixel_actions_name_what_is_under_them_and_refuse_ids() -> None:
    env = HouseEnv(split="vision")
    try:
        assert set(env.action_space.spaces) == {"primitive", "move", "target_px", "tool_px"}
        assert {"nothing_there", "ids_not_accepted"} <= set(REASONS)
        env.reset(seed=SEED)
        _, _, _, _, info = env.step(make_action("pick", target=5))
        assert _reason(info) == "ids_not_accepted"
        _, _, _, _, info = env.step(make_pixel_action("pick"))  # names nothing at all
        assert _reason(info) == "invalid_action"
        _, _, _, _, info = env.step(make_pixel_action("pick", target_px=(256, 0)))
        assert _reason(info) == "invalid_action"  # outside the 256x192 frame
        seg = env.last_segmentation()
        assert seg is not None
        vs, us = np.nonzero(seg == -1)
        empty = (int(us[0]), int(vs[0]))
        _, _, _, _, info = env.step(make_pixel_action("pick", target_px=empty))
        assert _reason(info) == "nothing_there" and env.resolved == (None, None)
        for _ in range(8):  # turn until something is in view
            seg = env.last_segmentation()
            assert seg is not None
            if (seg >= 0).any():
                break
            env.step(make_pixel_action("move", turn=1.0))
        assert (seg >= 0).any(), "nothing in view all around"
        vs, us = np.nonzero(seg >= 0)
        thing = (int(us[0]), int(vs[0]))
        under = int(seg[thing[1], thing[0]])
        assert env.instance_at(thing) == under
        _, _, _, _, info = env.step(make_pixel_action("close", target_px=thing))
        assert env.resolved == (under, None)
        assert _reason(info) not in ("nothing_there", "invalid_action", "unknown_id")
        # use: the tool by pixel, or (no tool_px) the held item; the hand is empty here.
        _, _, _, _, info = env.step(make_pixel_action("use", target_px=thing))
        assert _reason(info) == "tool_not_held" and env.resolved == (under, -1)
        _, _, _, _, info = env.step(make_pixel_action("use", target_px=thing, tool_px=empty))
        assert _reason(info) == "nothing_there"
        # moves take no pixel and meet none of these checks
        _, _, _, _, info = env.step(make_pixel_action("move", turn=0.2))
        assert info["action_result"]["ok"]
    finally:
        env.close()


def test_parse_pixel_action_checks_the_pixel() -> None:
    size = (256, 192)
    ok = parse_pixel_action({"primitive": "pick", "target_px": [255, 191]}, size)
    assert ok == ("pick", 0.0, 0.0, (255, 191), None)
    assert parse_pixel_action({"primitive": "pick", "target_px": [1.0, 2.0]}, size)[3] == (1, 2)
    for bad in ([1.5, 2], [-1, 0], [0, 192], [1, 2, 3], "a", [float("nan"), 0]):
        out = parse_pixel_action({"primitive": "pick", "target_px": bad}, size)
        assert getattr(out, "reason", None) == "invalid_action", bad
    refused = parse_pixel_action({"primitive": "use", "target_px": [1, 1], "tool": 3}, size)
    assert getattr(refused, "reason", None) == "ids_not_accepted"


def test_actions_by_pixel_need_frames_and_other_splits_keep_ids() -> None:
    with pytest.raises(ValueError, match="render_rgbd"):
        HouseEnv(split="vision", render_rgbd=False)
    for split in ("dev", "standard", "challenge"):
        cfg = house_split(split).config
        assert (cfg.detections, cfg.segmentation, cfg.actions_by) == (True, True, "id")
    env = HouseEnv(split="standard")
    try:
        assert set(env.action_space.spaces) == {"primitive", "move", "target", "tool"}
    finally:
        env.close()


def test_held_is_a_flag_on_vision_and_an_id_elsewhere() -> None:
    flag, ids = HouseEnv(split="standard", held="flag"), HouseEnv(split="standard")
    try:
        assert house_split("vision").config.held == "flag"
        assert all(house_split(s).config.held == "id" for s in ("dev", "standard", "challenge"))
        box = flag.observation_space["held"]
        assert (int(box.low[0]), int(box.high[0])) == (0, 1)
        assert int(ids.observation_space["held"].low[0]) == -1
        obs_f, info_f = flag.reset(seed=SEED)
        obs_i, info_i = ids.reset(seed=SEED)
        assert obs_f["held"].tolist() == [0] and obs_i["held"].tolist() == [-1]
        assert (info_f["held"], info_i["held"]) == (0, -1)  # gymnasium's info says the same
        truth = ids.ground_truth()
        layout = ids.layout
        item = next(o for o in truth.objects
                    if getattr(layout.entity(o.receptacle), "opening", "") == "none")
        access = truth.receptacle(item.receptacle)
        assert access is not None
        for env in (flag, ids):
            env.teleport_robot(*access.access)
        obs_f, _, _, _, info = flag.step(make_action("pick", target=item.id))
        obs_i, _, _, _, info_i = ids.step(make_action("pick", target=item.id))
        assert info["action_result"]["ok"], info["action_result"]
        assert obs_f["held"].tolist() == [1] and obs_i["held"].tolist() == [item.id]
        assert (info["held"], info_i["held"]) == (1, item.id)
        assert flag.observation_space.contains(obs_f)
    finally:
        flag.close()
        ids.close()
