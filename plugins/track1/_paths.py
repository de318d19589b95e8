"""Reference path lengths in a house, for the SPL-style efficiency score.

A path runs in straight lines inside rooms and crosses walls only at doorway centres; closed
doors are passable (the robot can open them), locked ones are not. It ignores furniture, so
it is a lower bound of what a robot must drive between two poses.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable, Sequence
from typing import Any

Point = tuple[float, float]


def geodesic(layout: Any, a: Point, b: Point, blocked: Iterable[int] = ()) -> float | None:
    """Shortest room-respecting distance from ``a`` to ``b``; None when no path is open."""
    skip = set(blocked)
    ra, rb = layout.room_at(*a), layout.room_at(*b)
    if ra == rb:
        return math.dist(a, b)
    doors = [d for d in layout.doors if d.id not in skip]
    # Nodes: 0 = a, 1 = b, 2.. = doorway centres.
    points: list[Point] = [a, b, *(d.centre for d in doors)]
    rooms: list[set[int]] = [{ra}, {rb}, *({*d.rooms} for d in doors)]
    best = {0: 0.0}
    heap = [(0.0, 0)]
    while heap:
        dist, node = heapq.heappop(heap)
        if node == 1:
            return dist
        if dist > best.get(node, math.inf):
            continue
        for other in range(1, len(points)):
            if other == node or not rooms[node] & rooms[other]:
                continue
            nd = dist + math.dist(points[node], points[other])
            if nd < best.get(other, math.inf):
                best[other] = nd
                heapq.heappush(heap, (nd, other))
    return None


def reference_length(
    layout: Any, waypoints: Sequence[tuple[Point, frozenset[int]]]
) -> float | None:
    """Length of a chain of legs; each waypoint carries the doors locked from it onwards."""
    total = 0.0
    for (a, blocked), (b, _) in zip(waypoints, waypoints[1:], strict=False):
        leg = geodesic(layout, a, b, blocked)
        if leg is None:
            return None
        total += leg
    return total
