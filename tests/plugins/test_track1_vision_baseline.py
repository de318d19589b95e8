"""The learned-vision baseline (examples/track1_vision): its image is the structured
planner's plus a numpy detector, and the committed detector sees the official houses.

The detector is checked on frames of houses it never saw (seeds far from its training
seeds, 3 * 10**7 on): from every piece of furniture's access pose, what it reports is
compared with the ground truth by position. The bars are well under what it reaches
(``train_detector.py`` prints its accuracies), so that they fail when it goes blind, not
when it is retrained. The baseline plays the ``vision`` split in its container in
``tests/orchestrator/test_track1_docker.py``; its Table IV row is
``tests/benchmarks/bench_track1_fidelity.py --vision A:B``.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from simhost.worlds.track1 import HouseEnv, PerturbationError

FOLDER = Path(__file__).resolve().parents[2] / "examples" / "track1_vision"
sys.path.insert(0, str(FOLDER))

from detector import Detector, camera_points, segments  # noqa: E402
from seeing import SeeingEnv, Tracker  # noqa: E402
from train_detector import _poses  # noqa: E402

SEEDS = (7100, 7101)


def test_the_image_is_the_structured_planners_plus_a_numpy_detector() -> None:
    dockerfile = (FOLDER / "Dockerfile").read_text()
    assert "FROM eagc/track1-structured:latest" in dockerfile.splitlines()
    copied = " ".join(line for line in dockerfile.splitlines() if line.startswith("COPY"))
    assert "*.py" in copied and "detector.npz" in copied
    assert not (FOLDER / "structured.py").exists(), "the planner has one copy"
    runtime = "\n".join(p.read_text() for p in FOLDER.glob("*.py")
                        if not p.name.startswith("train_"))
    for heavy in ("torch", "sklearn", "mujoco", "gymnasium", "scipy", "plugins"):
        assert f"import {heavy}" not in runtime and f"from {heavy}" not in runtime, heavy
    assert (FOLDER / "detector.npz").stat().st_size < 1 << 20, "a few hundred kB at most"


def test_segments_are_the_touching_pixels_of_one_class() -> None:
    labels = np.zeros((6, 8), np.int32)
    labels[0:2, 0:3] = 1  # one block of class 1
    labels[4:6, 0:2] = 1  # another, apart
    labels[0:6, 5] = 2  # a column of class 2 ...
    labels[2, 3:5] = 2  # ... with an arm: still one
    labels[2, 2] = 1  # touches the first block (class 1) and the arm (class 2)
    seg, n = segments(labels)
    assert n == 3
    assert seg[0, 0] == seg[2, 2] != seg[5, 0]
    assert seg[0, 5] == seg[2, 3] and seg[0, 5] not in (seg[0, 0], seg[5, 0])
    assert (seg[labels == 0] == 0).all()


def test_depth_back_projects_onto_the_things_the_camera_sees() -> None:
    env = HouseEnv(split="standard")
    try:
        env.reset(seed=SEEDS[0])
        truth = env.ground_truth()
        table = truth.furniture[0]
        env.teleport_robot(*table.access)
        obs, _ = env.observe()
        points = camera_points(obs["depth"])
        floor = points[obs["segmentation"] == -1][:, 2]
        assert np.median(np.abs(floor[floor < 0.3])) < 0.03, "the floor is at height 0"
        for o in truth.objects:
            mask = obs["segmentation"] == o.id
            if mask.sum() > 20:
                x, y, yaw = table.access
                rx, ry = np.median(points[mask][:, :2], axis=0)
                wx = x + math.cos(yaw) * rx - math.sin(yaw) * ry
                wy = y + math.sin(yaw) * rx + math.cos(yaw) * ry
                assert math.dist((wx, wy), o.position[:2]) < 0.1, o
    finally:
        env.close()


def _views() -> list[tuple[dict[str, Any], Any, Any]]:
    """Frames of two unseen houses, with their truth: from every access pose, and facing
    every door from both sides (the training script's views of those kinds)."""
    env = HouseEnv(split="standard")
    rng = np.random.default_rng(0)
    out = []
    try:
        for seed in SEEDS:
            env.reset(seed=seed)
            for what, pose, _toggle in _poses(env.ground_truth(), rng):
                if what not in ("access", "door"):
                    continue
                try:
                    env.teleport_robot(*pose)
                except PerturbationError:
                    continue
                obs, _ = env.observe()
                out.append((obs, env.ground_truth(), env.ground_truth().robot))
    finally:
        env.close()
    return out


@pytest.fixture(scope="module")
def seen() -> list[tuple[list[dict[str, Any]], Any, Any]]:
    detector = Detector()
    return [(detector.detect(obs["rgb"], obs["depth"]), truth, pose)
            for obs, truth, pose in _views()]


def _world(robot: Any, rel: tuple[float, float]) -> tuple[float, float]:
    x, y, yaw = robot.x, robot.y, robot.yaw
    return (x + math.cos(yaw) * rel[0] - math.sin(yaw) * rel[1],
            y + math.sin(yaw) * rel[0] + math.cos(yaw) * rel[1])


def test_the_detector_names_furniture_and_items_it_never_saw(seen: list) -> None:
    big_right = big = item_right = items = 0
    for found, truth, pose in seen:
        for d in found:
            at = _world(pose, d["rel_pos"])
            if d["kind"] in ("furniture", "container"):
                near = min((*truth.furniture, *truth.containers),
                           key=lambda f: math.dist(f.position, at))
                big += 1
                big_right += near.category == d["category"] and math.dist(
                    near.position, at) < 1.0
            elif d["kind"] in ("object", "tool"):
                near = min(truth.objects, key=lambda o: math.dist(o.position[:2], at))
                items += 1
                item_right += (near.category, near.colour) == (d["category"], d["colour"]) \
                    and math.dist(near.position[:2], at) < 0.3
    assert big >= 20 and items >= 20, (big, items)
    print(f"furniture named right {big_right}/{big}, items {item_right}/{items}")
    assert big_right / big > 0.6, f"furniture named right {big_right}/{big}"
    assert item_right / items > 0.4, (
        f"items named right (category and colour) {item_right}/{items}")


def test_a_doors_position_is_its_doorways_not_its_panels(seen: list) -> None:
    errors = []
    for found, truth, pose in seen:
        for d in found:
            if d["kind"] == "door":
                at = _world(pose, d["rel_pos"])
                errors.append(min(math.dist(door.position, at) for door in truth.doors))
    assert len(errors) >= 10, errors
    print(f"door errors: median {np.median(errors):.2f} m of {len(errors)}")
    assert float(np.median(errors)) < 0.35, errors


def test_the_tracker_keeps_an_id_per_thing_and_actions_leave_by_pixel() -> None:
    tracker = Tracker()
    mug = {"kind": "object", "category": "mug", "rel_pos": (1.0, 0.0), "height": 0.8}
    first = tracker.assign((0.0, 0.0, 0.0), [dict(mug)])[0]["id"]
    # The robot moved 0.5 m ahead and turned left: the same mug, seen from there.
    again = tracker.assign((0.5, 0.0, math.pi / 2), [dict(mug, rel_pos=(0.0, -0.5))])
    assert again[0]["id"] == first
    other = tracker.assign((0.0, 0.0, 0.0), [dict(mug, rel_pos=(2.0, 1.0))])
    assert other[0]["id"] != first

    seeing = SeeingEnv.__new__(SeeingEnv)
    seeing.tracker, seeing.held, seeing.shape = tracker, first, (192, 256)
    seeing.pose = (0.0, 0.0, 0.0)
    seeing.frame = [dict(mug, id=first, pixel=(120, 150))]
    sent = seeing._by_pixel({"primitive": "use", "target": first, "tool": first})
    assert sent == {"primitive": "use", "target_px": [120, 150]}, "the held tool needs no pixel"
    seeing.frame = []  # not in the frame: where its place projects (2 m ahead, 1 m left,
    u, v = seeing._by_pixel({"primitive": "pick", "target": other[0]["id"]})["target_px"]
    assert 0 < u < 128 and 40 < v < 96, (u, v)  # 0.8 m high: left of centre, 15 degrees
    # above the optical axis (tilted 25 degrees down): above the centre row, not clamped)
