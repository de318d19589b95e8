"""Occupancy grid, breadth-first planning and path following, from the agent's range scans.

numpy only. The grid holds, per 10 cm cell, whether it was ever observed and an evidence
score (free scans lower it, scan hits and collisions raise it); a cell is an obstacle when
its score is positive. Planning inflates obstacles by the robot's radius and runs a
breadth-first wavefront (8-connected) from the robot until it meets a goal cell.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

RES = 0.1
SIZE = 400  # cells per side: 40 m, the house frame starts at (0, 0)
ORIGIN = -5.0
INFLATE = 3.1  # cells: robot radius 0.25 m plus a margin
SCAN_MAX = 8.0
FREE_RANGE = 6.0

_DISC = [(dx, dy) for dx in range(-4, 5) for dy in range(-4, 5)
         if dx * dx + dy * dy <= INFLATE * INFLATE]
_NEIGHBOURS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]


def _shift_or(mask: np.ndarray, offsets: list[tuple[int, int]]) -> np.ndarray:
    """``mask`` dilated by the given cell offsets."""
    out = mask.copy()
    h, w = mask.shape
    for dx, dy in offsets:
        xs, xd = (slice(0, h - dx), slice(dx, h)) if dx >= 0 else (slice(-dx, h), slice(0, h + dx))
        ys, yd = (slice(0, w - dy), slice(dy, w)) if dy >= 0 else (slice(-dy, w), slice(0, w + dy))
        out[xd, yd] |= mask[xs, ys]
    return out


def _dilate8(mask: np.ndarray) -> np.ndarray:
    """``mask`` grown by one cell in all 8 directions (separable: rows, then columns)."""
    rows = mask.copy()
    rows[1:] |= mask[:-1]
    rows[:-1] |= mask[1:]
    out = rows.copy()
    out[:, 1:] |= rows[:, :-1]
    out[:, :-1] |= rows[:, 1:]
    return out


class Grid:
    """The occupancy grid. Cell (i, j) covers x in [ORIGIN + i·RES, …), y likewise."""

    def __init__(self) -> None:
        self.known = np.zeros((SIZE, SIZE), bool)
        self.score = np.zeros((SIZE, SIZE), np.int8)
        self.lo = np.array([SIZE, SIZE])
        self.hi = np.array([0, 0])
        self._blocked: np.ndarray | None = None
        self._frontier: np.ndarray | None = None

    # ------------------------------------------------------------------ coordinates
    @staticmethod
    def cell(x: float, y: float) -> tuple[int, int]:
        i = min(max(int((x - ORIGIN) / RES), 0), SIZE - 1)
        j = min(max(int((y - ORIGIN) / RES), 0), SIZE - 1)
        return i, j

    @staticmethod
    def point(i: int, j: int) -> tuple[float, float]:
        return ORIGIN + (i + 0.5) * RES, ORIGIN + (j + 0.5) * RES

    # ------------------------------------------------------------------ updates
    def scan(self, x: float, y: float, yaw: float, ranges: np.ndarray) -> None:
        """Adds one range scan: the fan between neighbouring rays up to the nearer hit is
        free, the hits are obstacles."""
        n = len(ranges)
        r = int(FREE_RANGE / RES) + 2
        ci, cj = self.cell(x, y)
        i0, i1 = max(0, ci - r), min(SIZE, ci + r + 1)
        j0, j1 = max(0, cj - r), min(SIZE, cj + r + 1)
        xs = ORIGIN + (np.arange(i0, i1) + 0.5) * RES - x
        ys = ORIGIN + (np.arange(j0, j1) + 0.5) * RES - y
        dx, dy = np.meshgrid(xs, ys, indexing="ij")
        dist = np.hypot(dx, dy)
        ang = np.mod(np.arctan2(dy, dx) - yaw, 2 * math.pi) / (2 * math.pi / n)
        k = np.floor(ang).astype(int) % n
        reach = np.minimum(ranges[k], ranges[(k + 1) % n])
        free = (dist < np.minimum(reach - 0.15, FREE_RANGE)) | (dist < 0.3)
        view = self.score[i0:i1, j0:j1]
        view[free] = np.maximum(view[free] - 1, -4)
        self.known[i0:i1, j0:j1] |= free
        angles = yaw + np.arange(n) * (2 * math.pi / n)
        for a, d in zip(angles, ranges, strict=True):
            if d < SCAN_MAX - 0.05:
                self.mark(x + (d + 0.03) * math.cos(a), y + (d + 0.03) * math.sin(a), 3)
        self.lo = np.minimum(self.lo, [i0, j0])
        self.hi = np.maximum(self.hi, [i1, j1])
        self._blocked = None

    def mark(self, x: float, y: float, amount: int = 3) -> None:
        i, j = self.cell(x, y)
        self.score[i, j] = min(6, int(self.score[i, j]) + amount)
        self.known[i, j] = True
        self._blocked = None

    def clear(self, x: float, y: float, radius: float) -> None:
        """Forgets obstacles around a point (e.g. a doorway after its door opened)."""
        i, j = self.cell(x, y)
        r = int(radius / RES) + 1
        ii, jj = np.mgrid[i - r:i + r + 1, j - r:j + r + 1]
        mask = (ii - i) ** 2 + (jj - j) ** 2 <= (radius / RES) ** 2
        view = self.score[i - r:i + r + 1, j - r:j + r + 1]
        view[mask] = np.minimum(view[mask], -2)
        self._blocked = None

    # ------------------------------------------------------------------ queries
    def occupied(self) -> np.ndarray:
        return self.score > 0

    def _window(self) -> tuple[slice, slice]:
        """The part of the grid seen so far, with a margin."""
        lo = np.maximum(self.lo - 20, 0)
        hi = np.minimum(self.hi + 20, SIZE)
        return slice(int(lo[0]), int(hi[0])), slice(int(lo[1]), int(hi[1]))

    def blocked(self) -> np.ndarray:
        """Obstacles inflated by the robot's radius."""
        if self._blocked is None:
            win = self._window()
            self._blocked = np.zeros((SIZE, SIZE), bool)
            self._blocked[win] = _shift_or(self.score[win] > 0, _DISC)
            self._frontier = None
        return self._blocked

    def frontier(self) -> np.ndarray:
        """Known free cells next to unknown cells."""
        blocked = self.blocked()
        if self._frontier is None:
            win = self._window()
            known = self.known[win]
            free = known & ~(self.score[win] > 0)
            near = _shift_or(~known, [(1, 0), (-1, 0), (0, 1), (0, -1)])
            self._frontier = np.zeros((SIZE, SIZE), bool)
            self._frontier[win] = free & near & ~blocked[win]
        return self._frontier

    def escape(self, x: float, y: float) -> tuple[float, float] | None:
        """When the robot stands too close to an obstacle: the nearest clear cell (within
        0.8 m), else None (it is clear already, or boxed in)."""
        i, j = self.cell(x, y)
        blocked = self.blocked()
        if not blocked[i, j]:
            return None
        r = 8
        window = ~blocked[i - r:i + r + 1, j - r:j + r + 1] & self.known[i - r:i + r + 1,
                                                                         j - r:j + r + 1]
        cells = np.argwhere(window)
        if len(cells) == 0:
            return None
        k = int(np.argmin(((cells - r) ** 2).sum(axis=1)))
        return self.point(int(cells[k][0]) + i - r, int(cells[k][1]) + j - r)

    def line_free(self, a: tuple[float, float], b: tuple[float, float]) -> bool:
        """Whether the straight segment between two points avoids inflated obstacles."""
        blocked = self.blocked()
        n = max(2, int(math.dist(a, b) / (RES / 2)))
        for t in np.linspace(0.0, 1.0, n):
            i, j = self.cell(a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t)
            if blocked[i, j]:
                return False
        return True

    # ------------------------------------------------------------------ planning
    def plan(self, start: tuple[float, float], goal: Callable[[np.ndarray, np.ndarray], np.ndarray],
             *, unknown_ok: bool = True, max_steps: int = 900,
             opened: list[tuple[float, float, float]] | None = None,
             ) -> list[tuple[float, float]] | None:
        """Path (cell centres) from ``start`` to the nearest cell where ``goal(xs, ys)`` holds
        (a boolean mask over the window's cell centre coordinates), or None. ``opened``:
        discs (x, y, radius) planned through as if free (closed doors, opened on the way)."""
        lo = np.maximum(self.lo - 15, 0)
        hi = np.minimum(self.hi + 15, SIZE)
        blocked = self.blocked()[lo[0]:hi[0], lo[1]:hi[1]]
        known = self.known[lo[0]:hi[0], lo[1]:hi[1]]
        passable = ~blocked & (known | unknown_ok)
        si, sj = self.cell(*start)
        si, sj = si - lo[0], sj - lo[1]
        h, w = passable.shape
        if not (0 <= si < h and 0 <= sj < w):
            return None
        passable[si, sj] = True
        xs = ORIGIN + (np.arange(lo[0], hi[0]) + 0.5) * RES
        ys = ORIGIN + (np.arange(lo[1], hi[1]) + 0.5) * RES
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        for ox, oy, r in opened or ():
            passable |= np.hypot(gx - ox, gy - oy) <= r
        goals = goal(gx, gy) & passable
        if not goals.any():
            return None
        dist = np.full((h, w), -1, np.int32)
        front = np.zeros((h, w), bool)
        front[si, sj] = True
        dist[si, sj] = 0
        reached = front.copy()
        hit = None
        for k in range(1, max_steps):
            if (front & goals).any():
                hit = np.argwhere(front & goals)[0]
                break
            nxt = _dilate8(front) & passable & ~reached
            if not nxt.any():
                return None
            dist[nxt] = k
            reached |= nxt
            front = nxt
        if hit is None:
            return None
        path = [(int(hit[0]), int(hit[1]))]
        while dist[path[-1]] > 0:
            i, j = path[-1]
            d = dist[i, j]
            for di, dj in _NEIGHBOURS:
                a, b = i + di, j + dj
                if 0 <= a < h and 0 <= b < w and dist[a, b] == d - 1:
                    path.append((a, b))
                    break
            else:
                return None
        path.reverse()
        return [self.point(i + lo[0], j + lo[1]) for i, j in path]

    def distance_field(self, start: tuple[float, float], max_steps: int = 900
                       ) -> tuple[np.ndarray, np.ndarray]:
        """Steps from ``start`` to every reachable known cell (-1: unreachable), and the
        window's offset."""
        lo = np.maximum(self.lo - 15, 0)
        hi = np.minimum(self.hi + 15, SIZE)
        passable = (~self.blocked() & self.known)[lo[0]:hi[0], lo[1]:hi[1]]
        si, sj = self.cell(*start)
        si, sj = si - lo[0], sj - lo[1]
        h, w = passable.shape
        passable[si, sj] = True
        dist = np.full((h, w), -1, np.int32)
        front = np.zeros((h, w), bool)
        front[si, sj] = True
        dist[si, sj] = 0
        reached = front.copy()
        for k in range(1, max_steps):
            nxt = _dilate8(front) & passable & ~reached
            if not nxt.any():
                break
            dist[nxt] = k
            reached |= nxt
            front = nxt
        return dist, lo


def steer(pose: tuple[float, float, float], grid: Grid, path: list[tuple[float, float]],
          horizon: int = 16) -> tuple[list[float], int]:
    """The move ``[forward, turn]`` toward the farthest path point in straight sight (up to
    ``horizon`` points, 0.1 m apart, ahead), and how many path points it passes."""
    x, y, yaw = pose
    target, used = path[0], 0
    for k, p in enumerate(path[:horizon]):
        if grid.line_free((x, y), p) or k == 0:
            target, used = p, k
        else:
            break
    dx, dy = target[0] - x, target[1] - y
    dist = math.hypot(dx, dy)
    err = math.remainder(math.atan2(dy, dx) - yaw, math.tau)
    limit = math.pi / 4
    if abs(err) > limit * 1.05:
        return [0.0, math.copysign(1.0, err)], 0
    return [min(1.0, dist / 0.5), max(-1.0, min(1.0, err / limit))], used
