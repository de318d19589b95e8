"""The learned detector of the vision baseline: one RGB-D frame in, detections out.

Six small multilayer perceptrons, trained offline (``train_detector.py``) on frames and
instance segmentation rendered through the public gymnasium envs, and run here on numpy:

1. ``pixels``: per pixel, what it shows (``PIXEL_CLASSES``: floor and walls, a door, each
   furniture and container category, or a small item), from its colour, its height above
   the floor (the depth back-projected through the eye camera) and box-filtered colour and
   height around it at three scales (a texton-style context, as in Shotton et al.'s
   TextonBoost, here learned by an MLP instead of boosting);
2. each furniture pixel takes the class most furniture pixels around it have (wooden boxes
   look alike up close), and the pixels of one class that touch form a segment (one thing;
   two touching items of the same class merge); ``furniture`` names a furniture segment
   (``FURNITURE`` or ``CONTAINERS``) from its size, height, colour and the classes its
   pixels had;
3. ``items``: a small item segment's category (``ITEMS``, or none: not an item after all)
   and ``colours`` its colour, from the segment's physical size, shape, resting height and
   colour statistics; ``states``: whether a door or container segment is open, from its
   depth profile (a doorway or an open cabinet shows depth behind it); ``doorways``: where
   a door's doorway centre lies from its panel's (a door swung open stands beside its
   doorway), from the panel's ends and the depth beside them.

A detection is a dict shaped like the host's own detector's (``kind``, ``category``,
``colour``, ``state``, ``rel_pos`` in the robot's frame: x ahead, y left) plus the segment
itself (``mask``, ``pixel``: the pixel an action by pixel names, ``nearest_pixel``). Ids
are not the detector's business (``seeing.Tracker`` gives them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

FURNITURE = ("table", "counter", "shelf", "bed", "desk", "sofa")
CONTAINERS = ("cabinet", "drawer", "fridge", "bin")
OBJECTS = ("mug", "apple", "book", "plate", "towel", "bottle", "bowl", "bread", "plant")
TOOLS = ("sponge", "cloth", "knife", "scissors", "watering_can", "jug")
ITEMS = OBJECTS + TOOLS
COLOURS = ("red", "green", "blue", "yellow", "white", "black", "orange", "purple")
PIXEL_CLASSES = ("background", "door") + FURNITURE + CONTAINERS + ("item",)
"""What a pixel shows: index 0 floor, walls and nothing; the last a small item."""
ITEM_CLASS = len(PIXEL_CLASSES) - 1
BIG = FURNITURE + CONTAINERS
BIG_CLASSES = np.arange(2, 2 + len(BIG))
"""The pixel classes of furniture and containers (``PIXEL_CLASSES`` 2..11)."""
SMOOTH = 7
"""Half the window (pixels) over which a furniture pixel takes its neighbours' majority."""

EYE = np.array([0.14, 0.0, 1.2])
"""The eye camera's position in the robot's frame (x ahead, y left, z up; metres)."""
TILT = math.radians(25)
"""How far the camera looks down."""
FOVY = math.radians(75)
MIN_PIXELS = {"item": 6, "door": 150, "big": 120}
"""Smallest segment kept (pixels at 256 x 192): smaller ones are noise or too far to act on."""
MAX_RANGE = {"item": 3.2, "door": 5.0, "big": 5.0}
"""Farthest a segment is reported from (metres): farther, its pixels are too few to read."""
MIN_CONFIDENCE = 0.5
"""An item reading less sure than this is left out (a far or partial view: the planner
votes on every reading, so a guess would outvote a close look)."""
WEIGHTS = Path(__file__).resolve().parent / "detector.npz"


# ---------------------------------------------------------------------- geometry
def camera_points(depth: np.ndarray) -> np.ndarray:
    """Every pixel's point in the robot's frame, float32[H, W, 3], from planar depth."""
    h, w = depth.shape
    f = (h / 2) / math.tan(FOVY / 2)
    u = (np.arange(w, dtype=np.float32) + 0.5 - w / 2) / f
    v = (np.arange(h, dtype=np.float32) + 0.5 - h / 2) / f
    right = u[None, :] * depth  # along the camera's x axis: the robot's -y
    up = -v[:, None] * depth  # along the camera's y axis
    ahead = depth  # along the optical axis, tilted down
    c, s = math.cos(TILT), math.sin(TILT)
    x = EYE[0] + up * s + ahead * c
    y = EYE[1] - right
    z = EYE[2] + up * c - ahead * s
    return np.stack([x, np.broadcast_to(y, depth.shape), z], axis=-1).astype(np.float32)


def box_mean(a: np.ndarray, r: int) -> np.ndarray:
    """The mean over a (2r+1)-square window around each pixel (edges clamped), per channel."""
    pad = np.pad(a, ((r + 1, r), (r + 1, r)) + ((0, 0),) * (a.ndim - 2), mode="edge")
    s = pad.cumsum(0).cumsum(1)
    k = 2 * r + 1
    out = s[k:, k:] - s[:-k, k:] - s[k:, :-k] + s[:-k, :-k]
    return out / (k * k)


def pixel_features(rgb: np.ndarray, depth: np.ndarray, points: np.ndarray) -> np.ndarray:
    """float32[H, W, F]: what the pixel classifier reads at each pixel."""
    col = rgb.astype(np.float32) / 255.0
    z = np.clip(points[..., 2], -0.2, 2.5)[..., None]
    d = np.clip(depth, 0.0, 8.0)[..., None] / 4.0
    grey = col.mean(-1, keepdims=True)
    feats = [col, z, d, np.abs(np.diff(z, axis=0, prepend=z[:1])) * 10]
    for r in (2, 6, 14):
        feats += [box_mean(col, r), box_mean(z, r)]
    feats += [np.sqrt(np.maximum(box_mean(grey * grey, 4) - box_mean(grey, 4) ** 2, 0)) * 4,
              np.sqrt(np.maximum(box_mean(z * z, 4) - box_mean(z, 4) ** 2, 0)) * 4]
    h = rgb.shape[0]
    feats.append(np.broadcast_to((np.arange(h, dtype=np.float32) / h)[:, None, None],
                                 (h, rgb.shape[1], 1)))
    return np.concatenate(feats, axis=-1).astype(np.float32)


# ---------------------------------------------------------------------- segments
def smooth(labels: np.ndarray) -> np.ndarray:
    """The pixel classes with each furniture or container pixel set to the class most of
    the furniture pixels around it have: wooden boxes look alike up close, so a counter's
    pixels come out as patches of counter, shelf and cabinet; one class per piece makes
    one segment per piece (the ``furniture`` network then names it)."""
    big = (labels >= BIG_CLASSES[0]) & (labels <= BIG_CLASSES[-1])
    if not big.any():
        return labels
    votes = np.stack([box_mean((labels == c).astype(np.float32), SMOOTH)
                      for c in BIG_CLASSES])
    out = labels.copy()
    out[big] = BIG_CLASSES[votes.argmax(0)][big]
    return out


def big_histogram(raw: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """float32[10]: the share of each furniture and container class among a segment's
    pixels, before smoothing."""
    counts = np.bincount(raw[mask].ravel(), minlength=len(PIXEL_CLASSES))[BIG_CLASSES]
    return (counts / max(1, counts.sum())).astype(np.float32)


def segments(labels: np.ndarray) -> tuple[np.ndarray, int]:
    """4-connected components of equal nonzero labels: int32[H, W] (0: none) and their
    count. Runs of a row are joined to the touching runs above (union-find)."""
    h, w = labels.shape
    parent: list[int] = [0]

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    out = np.zeros((h, w), np.int32)
    prev: list[tuple[int, int, int, int]] = []  # (start, end, label, run id)
    for row in range(h):
        line = labels[row]
        cuts = np.flatnonzero(np.diff(line)) + 1
        starts = np.concatenate(([0], cuts))
        ends = np.concatenate((cuts, [w]))
        runs = []
        j = 0
        for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
            lab = int(line[a])
            if lab == 0:
                continue
            rid = len(parent)
            parent.append(rid)
            while j < len(prev) and prev[j][1] <= a:
                j += 1
            k = j
            while k < len(prev) and prev[k][0] < b:
                if prev[k][2] == lab:
                    ra, rb = find(rid), find(prev[k][3])
                    if ra != rb:
                        parent[max(ra, rb)] = min(ra, rb)
                k += 1
            out[row, a:b] = rid
            runs.append((a, b, lab, rid))
        prev = runs
    roots = np.array([find(i) for i in range(len(parent))], np.int32)
    _, dense = np.unique(roots, return_inverse=True)
    table = dense.astype(np.int32)  # root 0 (no run) maps to 0
    return table[out], int(table.max())


def segment_features(rgb: np.ndarray, depth: np.ndarray, points: np.ndarray,
                     mask: np.ndarray) -> np.ndarray:
    """float32[F]: what the item, colour and state classifiers read of one segment."""
    col = rgb[mask].astype(np.float32) / 255.0
    p = points[mask]
    d = depth[mask]
    dist = float(np.median(d))
    mean, std = col.mean(0), col.std(0)
    mx, mn = col.max(1), col.min(1)
    sat = float(np.mean((mx - mn) / (mx + 1e-3)))
    light = float(np.mean(mx))
    hue = _hue(mean)
    z = p[:, 2]
    xy = p[:, :2]
    span = np.ptp(xy, axis=0) if len(p) > 1 else np.zeros(2)
    rows, cols = np.nonzero(mask)
    r0, r1, c0, c1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
    box = depth[r0:r1, c0:c1]
    behind = float(np.mean((box > dist + 0.4) & ~mask[r0:r1, c0:c1]))
    fill = float(mask.sum()) / float((r1 - r0) * (c1 - c0))
    area = float(mask.sum()) * (dist / 100.0) ** 2 * 1e2
    flat = xy - xy.mean(0)
    ev = np.sqrt(np.maximum(np.linalg.eigvalsh(flat.T @ flat / max(1, len(flat) - 1)), 0))
    m2 = np.cov(np.stack([rows, cols]).astype(np.float64)) if len(rows) > 2 else np.eye(2)
    e2 = np.sqrt(np.maximum(np.linalg.eigvalsh(m2), 1e-6))
    chroma = (mx - mn) / (mx + 1e-3)
    hues = np.arctan2(math.sqrt(3) * (col[:, 1] - col[:, 2]),
                      2 * col[:, 0] - col[:, 1] - col[:, 2])
    coloured = chroma > 0.25
    hist = np.bincount(((hues[coloured] + math.pi) / (2 * math.pi) * 8).astype(int) % 8,
                       minlength=8)[:8] / max(1, len(col))
    return np.array([
        *mean, *std, sat, light, math.cos(hue), math.sin(hue),
        float(np.percentile(z, 10)), float(np.percentile(z, 90)), float(np.ptp(z)),
        float(np.hypot(*span)), area, fill, behind, dist / 4.0,
        float(np.percentile(d, 90) - np.percentile(d, 10)),
        float(np.mean(mn < 0.15)), float(np.mean(mn > 0.8)),
        float(ev[0]), float(ev[1]), float(e2[0] / e2[1]),
        *hist, float(np.mean(mx < 0.2)), float(np.mean((mn > 0.7) & (chroma < 0.2))),
    ], np.float32)


def door_features(depth: np.ndarray, points: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """float32[F]: what the doorway regressor reads of a door's segment: where the panel's
    left and right ends lie from its centre (robot frame), how far they are, and how much
    of the frame beside each end shows depth far behind the panel (an open doorway)."""
    rows, cols = np.nonzero(mask)
    p = points[mask]
    centre = np.median(p[:, :2], axis=0)
    dist = float(np.median(depth[mask]))
    c0, c1 = cols.min(), cols.max() + 1
    r0, r1 = rows.min(), rows.max() + 1
    edge = max(1, (c1 - c0) // 6)
    ends = []
    for sel in (cols < c0 + edge, cols >= c1 - edge):
        q = p[sel]
        ends += [*(np.median(q[:, :2], axis=0) - centre), float(np.median(depth[mask][sel]))
                 - dist]
    w = depth.shape[1]
    beside = []
    for a, b in ((max(0, c0 - 12), c0), (c1, min(w, c1 + 12))):
        band = depth[r0:r1, a:b]
        beside.append(float(np.mean(band > dist + 0.6)) if band.size else 0.0)
    return np.array([*ends, *beside, dist / 4.0, float(np.ptp(p[:, 2])), float(c1 - c0) / w,
                     (c0 + c1) / (2 * w) - 0.5], np.float32)


def _hue(c: np.ndarray) -> float:
    r, g, b = (float(x) for x in c)
    return math.atan2(math.sqrt(3) * (g - b), 2 * r - g - b)


# ---------------------------------------------------------------------- the networks
@dataclass(frozen=True)
class Mlp:
    """A trained multilayer perceptron (ReLU hidden layers, softmax out) on numpy."""

    mean: np.ndarray
    scale: np.ndarray
    weights: tuple[np.ndarray, ...]
    biases: tuple[np.ndarray, ...]

    def outputs(self, x: np.ndarray) -> np.ndarray:
        """The last layer's values (a regressor's prediction)."""
        a = (x - self.mean) / self.scale
        for k, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            a = a @ w + b
            if k < len(self.weights) - 1:
                np.maximum(a, 0, out=a)
        return a

    def probabilities(self, x: np.ndarray) -> np.ndarray:
        a = self.outputs(x)
        a -= a.max(-1, keepdims=True)
        np.exp(a, out=a)
        return a / a.sum(-1, keepdims=True)

    @classmethod
    def load(cls, data: Any, name: str) -> Mlp:
        n = int(data[f"{name}_layers"])
        return cls(data[f"{name}_mean"], data[f"{name}_scale"],
                   tuple(data[f"{name}_w{k}"] for k in range(n)),
                   tuple(data[f"{name}_b{k}"] for k in range(n)))

    def save(self, name: str) -> dict[str, np.ndarray]:
        out = {f"{name}_layers": np.array(len(self.weights)), f"{name}_mean": self.mean,
               f"{name}_scale": self.scale}
        for k, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            out[f"{name}_w{k}"], out[f"{name}_b{k}"] = w.astype(np.float32), b.astype(
                np.float32)
        return out


# ---------------------------------------------------------------------- the detector
class Detector:
    """Pixels in, detections out (see the module)."""

    def __init__(self, path: Path = WEIGHTS) -> None:
        with np.load(path) as data:
            self.pixels = Mlp.load(data, "pixels")
            self.items = Mlp.load(data, "items")
            self.colours = Mlp.load(data, "colours")
            self.states = Mlp.load(data, "states")
            self.doorways = Mlp.load(data, "doorways")
            self.furniture = Mlp.load(data, "furniture")

    def classify(self, rgb: np.ndarray, depth: np.ndarray, points: np.ndarray) -> np.ndarray:
        """int32[H, W]: the pixel classes (indices of ``PIXEL_CLASSES``)."""
        feats = pixel_features(rgb, depth, points)
        h, w, f = feats.shape
        labels = self.pixels.probabilities(feats.reshape(-1, f)).argmax(-1).reshape(h, w)
        labels[depth > 7.5] = 0
        return labels.astype(np.int32)

    def detect(self, rgb: np.ndarray, depth: np.ndarray) -> list[dict[str, Any]]:
        """The things in one frame, nearest first (see the module)."""
        points = camera_points(depth)
        raw = self.classify(rgb, depth, points)
        labels = smooth(raw)
        seg, n = segments(labels)
        if n == 0:
            return []
        counts = np.bincount(seg.ravel(), minlength=n + 1)
        found: list[dict[str, Any]] = []
        rows: list[np.ndarray] = []
        shares: list[np.ndarray] = []
        first = np.zeros(n + 1, np.int64)  # a pixel of each segment: its class is the class
        first[seg.ravel()[::-1]] = np.arange(seg.size)[::-1]
        for k in range(1, n + 1):
            cls = int(labels.ravel()[first[k]])
            group = "item" if cls == ITEM_CLASS else ("door" if cls == 1 else "big")
            if counts[k] < MIN_PIXELS[group]:
                continue
            mask = seg == k
            p = points[mask]
            dist = float(np.median(depth[mask]))
            if dist > MAX_RANGE[group]:
                continue
            centre = np.median(p[:, :2], axis=0)
            rows.append(segment_features(rgb, depth, points, mask))
            shares.append(big_histogram(raw, mask))
            if group == "door":  # the doorway's centre, not the panel's (it swings)
                centre = centre + self.doorways.outputs(
                    door_features(depth, points, mask)[None])[0]
            category = PIXEL_CLASSES[cls]
            kind = ("item" if group == "item" else "door" if group == "door"
                    else "container" if category in CONTAINERS else "furniture")
            found.append({"kind": kind, "category": category, "colour": "none",
                          "state": "none", "rel_pos": (float(centre[0]), float(centre[1])),
                          "mask": mask, "pixel": nearest_pixel(mask), "distance": dist,
                          "height": float(np.median(p[:, 2]))})
        if not found:
            return []
        feats = np.stack(rows)
        big_p = self.furniture.probabilities(np.concatenate([feats, np.stack(shares)], axis=1))
        for k, d in enumerate(found):
            if d["kind"] in ("furniture", "container"):
                d["category"] = BIG[int(big_p[k].argmax())]
                d["kind"] = "container" if d["category"] in CONTAINERS else "furniture"
        item_p = self.items.probabilities(feats)
        colour_p = self.colours.probabilities(feats)
        state_p = self.states.probabilities(np.concatenate(
            [feats, _kind_code([d["category"] for d in found])], axis=1))
        kept = []
        for k, d in enumerate(found):
            if d["kind"] == "item":
                best = int(item_p[k].argmax())
                if best >= len(ITEMS) or item_p[k, best] < MIN_CONFIDENCE:
                    continue  # not an item after all (the network's "none"), or unsure
                d["category"] = ITEMS[best]
                d["kind"] = "tool" if d["category"] in TOOLS else "object"
                d["colour"] = COLOURS[int(colour_p[k].argmax())]
                d["confidence"] = float(item_p[k].max())
            elif d["kind"] in ("door", "container"):
                d["state"] = "open" if state_p[k, 1] > 0.5 else "closed"
            kept.append(d)
        kept.sort(key=lambda d: d["distance"])
        return kept


def _kind_code(categories: list[str]) -> np.ndarray:
    """One-hot of door / each container category, beside a state row's segment features."""
    names = ("door",) + CONTAINERS
    out = np.zeros((len(categories), len(names)), np.float32)
    for k, c in enumerate(categories):
        if c in names:
            out[k, names.index(c)] = 1.0
    return out


def nearest_pixel(mask: np.ndarray) -> tuple[int, int]:
    """The pixel ``(u, v)`` (column, row) of a mask to act on: of its most eroded part
    (away from the mask's edges, where the detector's outline and the world's differ most),
    the pixel nearest the mask's centre."""
    core = mask
    for _ in range(6):
        inner = core.copy()
        inner[1:] &= core[:-1]
        inner[:-1] &= core[1:]
        inner[:, 1:] &= core[:, :-1]
        inner[:, :-1] &= core[:, 1:]
        if not inner.any():
            break
        core = inner
    rows, cols = np.nonzero(core)
    r, c = np.nonzero(mask)
    k = int(np.argmin((rows - r.mean()) ** 2 + (cols - c.mean()) ** 2))
    return int(cols[k]), int(rows[k])
