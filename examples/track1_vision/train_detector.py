#!/usr/bin/env python
"""Trains the vision baseline's detector offline, on frames rendered through the gymnasium
envs, and writes ``detector.npz`` (the weights ``detector.Detector`` runs on numpy).

    pip install scikit-learn   # training only: the agent runs the weights on numpy
    python examples/track1_vision/train_detector.py [--houses 60] [--out detector.npz]

Plays nothing. It resets the public envs (``eagc/House-v0`` and ``eagc/HouseChallenge-v0``,
the official splits' houses, dressed as the ``vision`` split shows them) on training seeds
(from 3 * 10**7 on, away from any evaluation seed and from the other baselines' training
seeds), and renders views a robot has while it works: from each piece of furniture's and
container's access pose and from farther back (its yaw jittered), each container shut and
open (the env's own ``open``/``close`` actions), each door from both sides, near and far,
open and shut, and each room from its centre. The labels are the frame's instance
segmentation and the house's ground truth (the env's organizer API, public offline).

It fits, with scikit-learn's ``MLPClassifier`` (Adam, early stopping on a held-out tenth):

- ``pixels``: a pixel's class (``detector.PIXEL_CLASSES``) from ``pixel_features``, on pixels
  sampled evenly per class from every frame;
- ``items``: an item segment's category, and ``colours``: its colour, from
  ``segment_features`` of the true masks;
- ``states``: a door's or container's open/shut state, from the same features and its kind;
- ``furniture``: a furniture segment's category, from the same features and the share of
  each furniture class among its pixels, on the segments the pixel network finds;
- ``doorways``: where a door's doorway centre lies from its panel's centre (a regressor).

Prints each network's accuracy on houses it never saw (the last tenth of the houses).
About 11 minutes on one core for 60 houses (9,260 views, about 4 GB of memory while it
runs); the weights are 83 kB.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
from detector import (
    BIG,
    COLOURS,
    CONTAINERS,
    ITEM_CLASS,
    ITEMS,
    PIXEL_CLASSES,
    WEIGHTS,
    Mlp,
    _kind_code,
    big_histogram,
    camera_points,
    door_features,
    pixel_features,
    segment_features,
    segments,
    smooth,
)

FIRST_SEED = 3 * 10**7
PER_CLASS = 40
"""Pixels sampled per class per frame (fewer where a class shows fewer)."""
MIN_SEGMENT = 6
FOUND_EVERY = 3
"""Every this many views, the item segments the pixel network finds are learned from too."""


def _poses(truth: object, rng: np.random.Generator) -> list[tuple[str, tuple, int | None]]:
    """Views of one house: (what, (x, y, yaw), the container or door toggled there)."""
    views: list[tuple[str, tuple, int | None]] = []
    rooms = {r.id: r for r in truth.rooms}

    def inside(x: float, y: float, room: int) -> bool:
        x0, y0, x1, y1 = rooms[room].bounds
        return x0 + 0.35 < x < x1 - 0.35 and y0 + 0.35 < y < y1 - 0.35

    for f in (*truth.furniture, *truth.containers):
        x, y, yaw = f.access
        toggle = f.id if f.kind == "container" else None
        views.append(("access", (x, y, yaw), toggle))
        for back in (0.6, 1.3, 2.2):
            j = yaw + rng.uniform(-0.45, 0.45)
            bx, by = x - back * math.cos(yaw), y - back * math.sin(yaw)
            if inside(bx, by, f.room):
                views.append(("back", (bx, by, j), None))
    for d in truth.doors:
        for room in d.rooms:
            x0, y0, x1, y1 = rooms[room].bounds
            cx, cy = rooms[room].centre
            vertical = min(abs(d.position[0] - x0), abs(d.position[0] - x1)) < 0.1
            nx, ny = ((1.0 if cx > d.position[0] else -1.0, 0.0) if vertical
                      else (0.0, 1.0 if cy > d.position[1] else -1.0))
            for k, dist in enumerate((1.0, 2.0, 3.2)):
                px, py = d.position[0] + nx * dist, d.position[1] + ny * dist
                if inside(px, py, room):
                    yaw = math.atan2(-ny, -nx) + rng.uniform(-0.3, 0.3) * (k > 0)
                    views.append(("door", (px, py, yaw), d.id if k == 0 else None))
            for side in (-1.0, 1.0):  # obliquely, from along the wall
                along = side * rng.uniform(0.6, 1.4)
                px = d.position[0] + nx * 1.4 + ny * along
                py = d.position[1] + ny * 1.4 + nx * along
                if inside(px, py, room):
                    yaw = math.atan2(d.position[1] - py, d.position[0] - px)
                    views.append(("door", (px, py, yaw), None))
    for r in truth.rooms:
        for _ in range(3):
            views.append(("room", (*r.centre, rng.uniform(-math.pi, math.pi)), None))
    return views


def _labels(truth: object) -> dict[int, tuple[int, str, str, str]]:
    """Per instance id: (pixel class, category, colour, state)."""
    out: dict[int, tuple[int, str, str, str]] = {}
    for d in truth.doors:
        out[d.id] = (1, "door", "none", "open" if d.state == "open" else "closed")
    for f in (*truth.furniture, *truth.containers):
        state = "open" if f.state == "open" else "closed"
        out[f.id] = (PIXEL_CLASSES.index(f.category), f.category, "none", state)
    for o in truth.objects:
        out[o.id] = (len(PIXEL_CLASSES) - 1, o.category, o.colour, "none")
    return out


def _relative(truth: object) -> dict[int, tuple[float, float]]:
    """Per door, its doorway's centre in the robot's frame (x ahead, y left), from the true
    pose."""
    r = truth.robot
    c, s = math.cos(r.yaw), math.sin(r.yaw)
    out = {}
    for d in truth.doors:
        dx, dy = d.position[0] - r.x, d.position[1] - r.y
        out[d.id] = (c * dx + s * dy, -s * dx + c * dy)
    return out


Frame = tuple[np.ndarray, np.ndarray, np.ndarray, dict, dict]
"""One rendered view: rgb, depth, segmentation, labels per id, doorways per id."""


class Samples:
    """What the frames teach, gathered per network."""

    def __init__(self) -> None:
        self.pixels: list[np.ndarray] = []
        self.pixel_y: list[np.ndarray] = []
        self.items: list[np.ndarray] = []
        self.item_y: list[int] = []
        self.colours: list[np.ndarray] = []
        self.colour_y: list[int] = []
        self.states: list[np.ndarray] = []
        self.state_y: list[int] = []
        self.doors: list[np.ndarray] = []
        self.door_y: list[np.ndarray] = []
        self.big: list[np.ndarray] = []
        self.big_y: list[int] = []

    def add(self, frame: Frame, rng: np.random.Generator) -> None:
        """The pixels of a frame, and each true instance's segment (its mask)."""
        rgb, depth, seg, labels, doorways = frame
        points = camera_points(depth)
        feats = pixel_features(rgb, depth, points)
        cls = np.zeros(seg.shape, np.int64)
        for i in np.unique(seg):
            if i >= 0 and int(i) in labels:
                cls[seg == i] = labels[int(i)][0]
        for c in np.unique(cls):
            where = np.flatnonzero(cls.ravel() == c)
            pick = rng.choice(where, min(PER_CLASS, len(where)), replace=False)
            self.pixels.append(feats.reshape(-1, feats.shape[-1])[pick])
            self.pixel_y.append(np.full(len(pick), c))
        for i in np.unique(seg):
            if i < 0 or int(i) not in labels:
                continue
            mask = seg == i
            if mask.sum() < MIN_SEGMENT or float(np.median(depth[mask])) > 5.0:
                continue
            c, category, colour, state = labels[int(i)]
            row = segment_features(rgb, depth, points, mask)
            if category in ITEMS:
                self.items.append(row)
                self.item_y.append(ITEMS.index(category))
                self.colours.append(row)
                self.colour_y.append(COLOURS.index(colour))
            elif category == "door" or category in CONTAINERS:
                self.states.append(np.concatenate([row, _kind_code([category])[0]]))
                self.state_y.append(int(state == "open"))
            if category == "door":  # the doorway's centre from the panel's, robot frame
                centre = np.median(points[mask][:, :2], axis=0)
                self.doors.append(door_features(depth, points, mask))
                self.door_y.append(np.asarray(doorways[int(i)]) - centre)

    def add_found(self, frame: Frame, pixels: Mlp) -> None:
        """The segments the pixel network finds in a frame, as the detector forms them.
        An item segment is labelled with the item most of its pixels show, else ``none``
        (a piece of furniture or wall taken for an item: the item network learns to drop
        it); a furniture segment with the category of the piece most of it shows, if it
        shows one."""
        rgb, depth, seg, labels, _doorways = frame
        points = camera_points(depth)
        feats = pixel_features(rgb, depth, points)
        h, w, f = feats.shape
        raw = pixels.probabilities(feats.reshape(-1, f)).argmax(-1).reshape(h, w)
        raw = raw.astype(np.int32)
        raw[depth > 7.5] = 0
        found = smooth(raw)
        parts, n = segments(found)
        for k in range(1, n + 1):
            mask = parts == k
            cls = int(found[mask][0])
            if cls < 2 or mask.sum() < MIN_SEGMENT or float(np.median(depth[mask])) > 5.0:
                continue
            ids, counts = np.unique(seg[mask], return_counts=True)
            top = int(ids[counts.argmax()])
            category = labels.get(top, (0, "none"))[1]
            row = segment_features(rgb, depth, points, mask)
            if cls == ITEM_CLASS:
                self.items.append(row)
                self.item_y.append(ITEMS.index(category) if category in ITEMS else len(ITEMS))
            elif category in BIG and counts.max() >= 0.5 * mask.sum() and mask.sum() >= 120:
                self.big.append(np.concatenate([row, big_histogram(raw, mask)]))
                self.big_y.append(BIG.index(category))


def gather(houses: int, seed0: int) -> list[Frame]:
    """Views of ``houses`` houses from ``seed0`` on (see the module)."""
    import gymnasium as gym

    import simhost.worlds.track1  # noqa: F401 - registers the Track 1 envs
    from simhost.worlds.track1 import PerturbationError

    rng = np.random.default_rng(seed0)
    frames: list[Frame] = []
    envs = [gym.make(i, render_rgbd=True).unwrapped
            for i in ("eagc/House-v0", "eagc/HouseChallenge-v0")]

    def keep(obs: dict) -> None:
        truth = env.ground_truth()
        frames.append((obs["rgb"], obs["depth"], obs["segmentation"].astype(np.int16),
                       _labels(truth), _relative(truth)))

    for k in range(houses):
        env = envs[k % 2]
        env.reset(seed=seed0 + k)
        for _what, pose, toggle in _poses(env.ground_truth(), rng):
            try:
                env.teleport_robot(*pose)
            except PerturbationError:  # the pose collides with the house: no such view
                continue
            keep(env.observe()[0])
            if toggle is not None:
                truth = env.ground_truth()
                state = next((x.state for x in (*truth.doors, *truth.containers)
                              if x.id == toggle), "locked")
                if state in ("open", "closed"):
                    prim = "close" if state == "open" else "open"
                    env.step({"primitive": prim, "target": toggle})
                    env.teleport_robot(*pose)
                    keep(env.observe()[0])
    for env in envs:
        env.close()
    return frames


def fit(x: np.ndarray, y: np.ndarray, hidden: tuple[int, ...], seed: int) -> Mlp:
    from sklearn.neural_network import MLPClassifier

    mean, scale = x.mean(0), x.std(0) + 1e-6
    net = MLPClassifier(hidden_layer_sizes=hidden, early_stopping=True, max_iter=40,
                        random_state=seed, batch_size=512, alpha=1e-4)
    net.fit((x - mean) / scale, y)
    n_out = int(y.max()) + 1
    weights, biases = list(net.coefs_), list(net.intercepts_)
    classes = net.classes_.astype(int)
    if weights[-1].shape[1] == 1:  # binary: sklearn keeps one logit; make it two
        weights[-1] = np.concatenate([np.zeros_like(weights[-1]), weights[-1]], axis=1)
        biases[-1] = np.concatenate([np.zeros_like(biases[-1]), biases[-1]])
    else:  # classes never seen get an output that never wins
        w = np.zeros((weights[-1].shape[0], n_out))
        b = np.full(n_out, -1e4)
        w[:, classes], b[classes] = weights[-1], biases[-1]
        weights[-1], biases[-1] = w, b
    return Mlp(mean.astype(np.float32), scale.astype(np.float32),
               tuple(np.asarray(w, np.float32) for w in weights),
               tuple(np.asarray(b, np.float32) for b in biases))


def fit_regressor(x: np.ndarray, y: np.ndarray, hidden: tuple[int, ...], seed: int) -> Mlp:
    from sklearn.neural_network import MLPRegressor

    mean, scale = x.mean(0), x.std(0) + 1e-6
    net = MLPRegressor(hidden_layer_sizes=hidden, early_stopping=True, max_iter=400,
                       random_state=seed, alpha=1e-4)
    net.fit((x - mean) / scale, y)
    return Mlp(mean.astype(np.float32), scale.astype(np.float32),
               tuple(np.asarray(w, np.float32) for w in net.coefs_),
               tuple(np.asarray(b, np.float32) for b in net.intercepts_))


def accuracy(net: Mlp, x: np.ndarray, y: np.ndarray) -> float:
    return float(np.mean(net.probabilities(x).argmax(-1) == y)) if len(y) else float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--houses", type=int, default=60)
    ap.add_argument("--out", type=Path, default=WEIGHTS)
    args = ap.parse_args()
    t0 = time.monotonic()
    held_out = max(2, args.houses // 10)
    frames = gather(args.houses - held_out, FIRST_SEED)
    unseen = gather(held_out, FIRST_SEED + 10**6)
    print(f"rendered {args.houses} houses ({len(frames) + len(unseen)} views) in "
          f"{time.monotonic() - t0:.0f} s")
    rng = np.random.default_rng(0)
    train, test = Samples(), Samples()
    for frame in frames:
        train.add(frame, rng)
    for frame in unseen:
        test.add(frame, rng)
    saved: dict[str, np.ndarray] = {}

    def report(name: str, net: Mlp, y: np.ndarray, quality: str) -> None:
        saved.update(net.save(name))
        print(f"{name:<8} {len(y):>7} samples  {quality}  ({time.monotonic() - t0:.0f} s)",
              flush=True)

    x, y = np.concatenate(train.pixels), np.concatenate(train.pixel_y)
    pixels = fit(x, y, (64, 48), seed=1)
    report("pixels", pixels, y, "accuracy on unseen houses "
           f"{accuracy(pixels, np.concatenate(test.pixels), np.concatenate(test.pixel_y)):.3f}")
    for frame in frames[::FOUND_EVERY]:  # what the pixel network finds, as it finds it
        train.add_found(frame, pixels)
    for frame in unseen[::FOUND_EVERY]:
        test.add_found(frame, pixels)
    for name, hidden, (xs, ys), (xt, yt) in (
            ("items", (64, 32), (train.items, train.item_y), (test.items, test.item_y)),
            ("colours", (32,), (train.colours, train.colour_y),
             (test.colours, test.colour_y)),
            ("states", (32,), (train.states, train.state_y), (test.states, test.state_y)),
            ("furniture", (64, 32), (train.big, train.big_y), (test.big, test.big_y))):
        net = fit(np.stack(xs), np.array(ys), hidden, seed=1)
        report(name, net, np.array(ys),
               f"accuracy on unseen houses {accuracy(net, np.stack(xt), np.array(yt)):.3f}")
    net = fit_regressor(np.stack(train.doors), np.stack(train.door_y), (32, 32), seed=1)
    err = np.linalg.norm(net.outputs(np.stack(test.doors)) - np.stack(test.door_y), axis=1)
    before = np.linalg.norm(np.stack(test.door_y), axis=1)
    report("doorways", net, np.stack(train.door_y),
           f"median error on unseen houses {np.median(err):.2f} m (the panel's centre: "
           f"{np.median(before):.2f} m)")
    np.savez_compressed(args.out, **saved)
    print(f"wrote {args.out} ({args.out.stat().st_size / 1024:.0f} kB)")


if __name__ == "__main__":
    main()
