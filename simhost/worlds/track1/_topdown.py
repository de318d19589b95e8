"""Top-down pictures of a house (numpy and the standard library only; PNG via zlib)."""

from __future__ import annotations

import math
import os
import struct
import zlib
from collections.abc import Sequence
from typing import Protocol

import numpy as np

from ._catalogue import RGBA, ROOM_FLOOR_RGBA
from ._layout import HouseLayout
from ._truth import HouseTruth
from ._world import WorldState, ground_truth

Colour = tuple[int, int, int]
_WALL: Colour = (55, 55, 60)
_DOOR: dict[str, Colour] = {
    "open": (40, 170, 70),
    "closed": (240, 150, 30),
    "locked": (210, 30, 30),
}
_FURNITURE: Colour = (150, 112, 74)
_CONTAINER: dict[str, Colour] = {
    "open": (150, 190, 230),
    "closed": (70, 105, 160),
    "unavailable": (95, 95, 95),
}
_ROBOT: Colour = (40, 40, 190)
_PATH: Colour = (225, 0, 200)
_TEXT: Colour = (25, 25, 25)

_GLYPHS = {
    "0": "111101101101111",
    "1": "010110010010111",
    "2": "111001111100111",
    "3": "111001111001111",
    "4": "101101111001001",
    "5": "111100111001111",
    "6": "111100111101111",
    "7": "111001010010010",
    "8": "111101111101111",
    "9": "111101111001111",
    "A": "010101111101101",
    "B": "110101110101110",
    "C": "011100100100011",
    "D": "110101101101110",
    "E": "111100110100111",
    "F": "111100110100100",
    "G": "011100101101011",
    "H": "101101111101101",
    "I": "111010010010111",
    "J": "001001001101010",
    "K": "101101110101101",
    "L": "100100100100111",
    "M": "101111111101101",
    "N": "110101101101101",
    "O": "010101101101010",
    "P": "110101110100100",
    "Q": "010101101110011",
    "R": "110101110101101",
    "S": "011100010001110",
    "T": "111010010010010",
    "U": "101101101101111",
    "V": "101101101101010",
    "W": "101101111111101",
    "X": "101101010101101",
    "Y": "101101010010010",
    "Z": "111001010100111",
    " ": "000000000000000",
    "-": "000000111000000",
    "#": "101111101111101",
    ".": "000000000000010",
    ",": "000000000010100",
    ":": "000010000010000",
    "/": "001001010100100",
    "(": "010100100100010",
    ")": "010001001001010",
    "%": "101001010100101",
    "=": "000111000111000",
}

TOPDOWN_LEGEND: tuple[tuple[str, Colour], ...] = (
    ("wall", _WALL),
    ("door open", _DOOR["open"]),
    ("door closed", _DOOR["closed"]),
    ("door locked", _DOOR["locked"]),
    ("furniture", _FURNITURE),
    ("container open", _CONTAINER["open"]),
    ("container closed", _CONTAINER["closed"]),
    ("unavailable", _CONTAINER["unavailable"]),
    ("robot", _ROBOT),
)
"""What the colours of ``render_topdown`` mean (objects are drawn in their own colour: discs,
tools squares)."""

TOPDOWN_SCALE = 48.0
"""Pixels per metre of ``render_topdown`` (its default)."""
TOPDOWN_MARGIN = 12
"""Pixels of white around the house in ``render_topdown``."""


def draw_text(img: np.ndarray, x: int, y: int, text: str, colour: Colour = _TEXT,
              size: int = 2) -> int:
    """Writes ``text`` (letters, digits and a little punctuation, in capitals) into an RGB
    image with its top-left corner at pixel (x, y); returns the x after the text."""
    h, w = img.shape[:2]
    for ch in text.upper():
        bits = _GLYPHS.get(ch, _GLYPHS["#"])
        for k, bit in enumerate(bits):
            if bit == "1":
                r, c = divmod(k, 3)
                a, b = y + r * size, x + c * size
                if 0 <= a and a + size <= h and 0 <= b and b + size <= w:
                    img[a : a + size, b : b + size] = colour
        x += 4 * size
    return x


class _HasTruth(Protocol):
    layout: HouseLayout

    def ground_truth(self) -> HouseTruth: ...


class _Canvas:
    def __init__(self, width_m: float, height_m: float, scale: float, margin: int) -> None:
        self.scale, self.margin, self.height_m = scale, margin, height_m
        w = int(math.ceil(width_m * scale)) + 2 * margin
        h = int(math.ceil(height_m * scale)) + 2 * margin
        self.img = np.full((h, w, 3), 255, dtype=np.uint8)

    def px(self, x: float, y: float) -> tuple[float, float]:
        return (self.margin + x * self.scale, self.margin + (self.height_m - y) * self.scale)

    def rect(self, x0: float, y0: float, x1: float, y1: float, colour: Colour) -> None:
        (a, b), (c, d) = self.px(x0, y1), self.px(x1, y0)
        h, w = self.img.shape[:2]
        i0, i1 = max(0, int(round(a))), min(w, int(round(c)))
        j0, j1 = max(0, int(round(b))), min(h, int(round(d)))
        if i1 > i0 and j1 > j0:
            self.img[j0:j1, i0:i1] = colour

    def outline(self, x0: float, y0: float, x1: float, y1: float, colour: Colour, t: float) -> None:
        self.rect(x0, y0, x1, y0 + t, colour)
        self.rect(x0, y1 - t, x1, y1, colour)
        self.rect(x0, y0, x0 + t, y1, colour)
        self.rect(x1 - t, y0, x1, y1, colour)

    def disc(self, x: float, y: float, radius: float, colour: Colour) -> None:
        cx, cy = self.px(x, y)
        r = max(radius * self.scale, 1.0)
        h, w = self.img.shape[:2]
        j0, j1 = max(0, int(cy - r - 1)), min(h, int(cy + r + 2))
        i0, i1 = max(0, int(cx - r - 1)), min(w, int(cx + r + 2))
        if i1 <= i0 or j1 <= j0:
            return
        jj, ii = np.mgrid[j0:j1, i0:i1]
        mask = (ii + 0.5 - cx) ** 2 + (jj + 0.5 - cy) ** 2 <= r * r
        self.img[j0:j1, i0:i1][mask] = colour

    def line(
        self, x0: float, y0: float, x1: float, y1: float, colour: Colour, width: float
    ) -> None:
        n = max(2, int(math.hypot(x1 - x0, y1 - y0) * self.scale * 2))
        for t in np.linspace(0.0, 1.0, n):
            self.disc(x0 + (x1 - x0) * t, y0 + (y1 - y0) * t, width / 2, colour)

    def text(
        self,
        x: float,
        y: float,
        label: str,
        colour: Colour,
        size: int = 2,
        background: Colour | None = None,
    ) -> None:
        cx, cy = self.px(x, y)
        i = int(cx - len(label) * 4 * size / 2)
        j = int(cy - 5 * size / 2)
        h, w = self.img.shape[:2]
        if background is not None:
            a, b = max(0, j - size), min(h, j + 6 * size)
            c, d = max(0, i - 2 * size), min(w, i + len(label) * 4 * size + size)
            self.img[a:b, c:d] = (0.35 * self.img[a:b, c:d] + 0.65 * np.array(background)).astype(
                np.uint8
            )
        for ch in label.upper():
            bits = _GLYPHS.get(ch, _GLYPHS["#"])
            for k, bit in enumerate(bits):
                if bit == "1":
                    r, c = divmod(k, 3)
                    a, b = j + r * size, i + c * size
                    if 0 <= a and a + size <= h and 0 <= b and b + size <= w:
                        self.img[a : a + size, b : b + size] = colour
            i += 4 * size


def _rgb(rgba: tuple[float, float, float, float]) -> Colour:
    return (int(rgba[0] * 255), int(rgba[1] * 255), int(rgba[2] * 255))


def render_topdown(
    layout_or_env: HouseLayout | _HasTruth,
    *,
    path: str | os.PathLike[str] | None = None,
    trajectory: Sequence[Sequence[float]] | None = None,
    scale: float = 48.0,
) -> np.ndarray:
    """Draw a house from above: rooms, walls, doors by state, furniture, objects, the robot.

    Args:
        layout_or_env: a layout (drawn in its initial state) or a ``HouseEnv`` (drawn as it
            is now).
        path: if given, also write the picture there as a PNG.
        trajectory: optional (x, y, ...) points drawn as a polyline.
        scale: pixels per metre.

    Returns:
        The picture, uint8[H, W, 3]. Doors: green open, orange closed, red locked; containers:
        light blue open, dark blue closed, grey unavailable; tools are squares, objects discs.
    """
    if isinstance(layout_or_env, HouseLayout):
        layout = layout_or_env
        truth = ground_truth(layout, WorldState.initial(layout), layout.start, (0.0, 0.0, 0.0))
    else:
        layout = layout_or_env.layout
        truth = layout_or_env.ground_truth()
    width, height = layout.extent
    cv = _Canvas(width, height, scale, margin=12)
    for room in layout.rooms:
        cv.rect(*room.bounds, _rgb(ROOM_FLOOR_RGBA[room.type]))
    for wall in layout.walls:
        (cx, cy), (hx, hy) = wall.centre, wall.half
        cv.rect(cx - hx, cy - hy, cx + hx, cy + hy, _WALL)
    states = {d.id: d.state for d in truth.doors}
    for door in layout.doors:
        colour = _DOOR[states[door.id]]
        hx, hy = door.hinge
        angle = door.yaw + (door.open_angle if states[door.id] == "open" else 0.0)
        ex, ey = hx + math.cos(angle) * door.width, hy + math.sin(angle) * door.width
        cv.line(hx, hy, ex, ey, colour, 0.09)
        nx, ny = door.swing_normal
        mx, my = door.centre
        cv.text(mx - nx * 0.4, my - ny * 0.4, f"D{door.id}", colour, 2, background=(255, 255, 255))
    for entry in (*truth.furniture, *truth.containers):
        f = layout.entity(entry.id)
        assert f is not None and hasattr(f, "footprint")
        x0, y0, x1, y1 = f.footprint
        fill = _CONTAINER[entry.state] if entry.kind == "container" else _FURNITURE
        cv.rect(x0, y0, x1, y1, fill)
        cv.outline(x0, y0, x1, y1, (40, 30, 20), 0.03)
        fx, fy = f.front
        fcx, fcy = f.pos[0] + fx * (f.size[1] / 2 - 0.04), f.pos[1] + fy * (f.size[1] / 2 - 0.04)
        ax, ay = math.cos(f.yaw) * f.size[0] * 0.4, math.sin(f.yaw) * f.size[0] * 0.4
        cv.line(fcx - ax, fcy - ay, fcx + ax, fcy + ay, (255, 255, 255), 0.04)
        if entry.state == "dirty":
            cv.disc(f.pos[0], f.pos[1], 0.06, (90, 70, 40))
        if entry.state == "unavailable":
            cv.line(x0, y0, x1, y1, (210, 30, 30), 0.06)
            cv.line(x0, y1, x1, y0, (210, 30, 30), 0.06)
    for obj in truth.objects:
        x, y = obj.position[:2]
        colour = _rgb(RGBA[obj.colour])
        if obj.kind == "tool":
            cv.rect(x - 0.1, y - 0.1, x + 0.1, y + 0.1, (0, 0, 0))
            cv.rect(x - 0.07, y - 0.07, x + 0.07, y + 0.07, colour)
        else:
            cv.disc(x, y, 0.1, (0, 0, 0))
            cv.disc(x, y, 0.07, colour)
    for room in layout.rooms:
        x0, y0, x1, y1 = room.bounds
        label = f"{room.id} {room.type.replace('_', ' ')}"
        cx, cy = room.centre
        cv.text(cx, cy + 0.6, label, _TEXT, 2, background=(255, 255, 255))
    if trajectory is not None and len(trajectory) > 1:
        for a, b in zip(trajectory, trajectory[1:], strict=False):
            cv.line(float(a[0]), float(a[1]), float(b[0]), float(b[1]), _PATH, 0.05)
    rx, ry, yaw = truth.robot.x, truth.robot.y, truth.robot.yaw
    cv.disc(rx, ry, 0.25, _ROBOT)
    cv.line(rx, ry, rx + math.cos(yaw) * 0.25, ry + math.sin(yaw) * 0.25, (255, 255, 255), 0.06)
    if path is not None:
        write_png(path, cv.img)
    return cv.img


def write_png(path: str | os.PathLike[str], image: np.ndarray) -> None:
    """Write an RGB uint8[H, W, 3] image as a PNG (zlib, no filter)."""
    img = np.ascontiguousarray(image, dtype=np.uint8)
    if img.ndim != 3 or img.shape[2] != 3:
        raise ValueError(f"expected an RGB image of shape (H, W, 3), got {img.shape}")
    h, w, _ = img.shape
    raw = np.concatenate([np.zeros((h, 1), np.uint8), img.reshape(h, w * 3)], axis=1)

    def chunk(tag: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(tag + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", crc)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw.tobytes(), 6)) + chunk(b"IEND", b"")
    with open(path, "wb") as fh:
        fh.write(png)
