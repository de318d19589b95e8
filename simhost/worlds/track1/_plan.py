"""Working data of the generator (plain dataclasses, not part of the public API)."""

from __future__ import annotations

from dataclasses import dataclass, field

from ._layout import WALL_THICKNESS
from ._mjcf import ROBOT_RADIUS as ROBOT_RADIUS  # re-exported for the generator

CLEARANCE = 0.05
ACCESS_DISTANCE = 0.45
"""Distance from a furniture front to its access pose's centre."""
RES = 0.1
WALL_T = WALL_THICKNESS
Rect = tuple[float, float, float, float]


@dataclass
class Segment:
    rooms: tuple[int, ...]
    vertical: bool
    line: float
    s0: float
    s1: float
    gaps: list[tuple[float, float]] = field(default_factory=list)


@dataclass
class Plan:
    col_widths: list[float]
    row_heights: list[float]
    cells: list[list[tuple[int, int]]]
    bounds: list[Rect]
    types: list[str] = field(default_factory=list)
    segments: list[Segment] = field(default_factory=list)
    pairs: list[tuple[int, int]] = field(default_factory=list)
    doors: list[dict] = field(default_factory=list)


@dataclass
class Piece:
    category: str
    room: int
    pos: tuple[float, float]
    yaw: float
    size: tuple[float, float, float]
    opening: str
    rect: Rect
    keep_out: Rect
    access: tuple[float, float, float]


def centre(rect: Rect) -> tuple[float, float]:
    """Centre of a rectangle."""
    return ((rect[0] + rect[2]) / 2, (rect[1] + rect[3]) / 2)


def overlap(a: Rect, b: Rect, gap: float = 0.0) -> bool:
    """Whether two axis-aligned rectangles (x0, y0, x1, y1) overlap, with a margin."""
    return a[0] < b[2] + gap and b[0] < a[2] + gap and a[1] < b[3] + gap and b[1] < a[3] + gap
