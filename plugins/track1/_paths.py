"""Reference paths in a house: the efficiency score's yardstick and the step budgets' base.

A path runs in straight lines inside rooms and crosses walls only at doorway centres; closed
doors are passable (the robot can open them), locked ones are not. It ignores furniture, so
it is a lower bound of what a robot must drive between two poses.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable, Sequence

from simhost.worlds.track1 import HouseLayout

Point = tuple[float, float]


def route(layout: HouseLayout, a: Point, b: Point, blocked: Iterable[int] = ()
          ) -> tuple[float, tuple[int, ...]] | None:
    """The shortest room-respecting path from ``a`` to ``b``: its length and the doors it
    crosses, in order; None when no path is open."""
    skip = set(blocked)
    ra, rb = layout.room_at(*a), layout.room_at(*b)
    if ra == rb:
        return math.dist(a, b), ()
    doors = [d for d in layout.doors if d.id not in skip]
    # Nodes: 0 = a, 1 = b, 2.. = doorway centres.
    points: list[Point] = [a, b, *(d.centre for d in doors)]
    rooms: list[set[int]] = [{ra}, {rb}, *({*d.rooms} for d in doors)]
    best = {0: 0.0}
    prev: dict[int, int] = {}
    heap = [(0.0, 0)]
    while heap:
        dist, node = heapq.heappop(heap)
        if node == 1:
            crossed, k = [], prev.get(1)
            while k is not None and k >= 2:
                crossed.append(doors[k - 2].id)
                k = prev.get(k)
            return dist, tuple(reversed(crossed))
        if dist > best.get(node, math.inf):
            continue
        for other in range(1, len(points)):
            if other == node or not rooms[node] & rooms[other]:
                continue
            nd = dist + math.dist(points[node], points[other])
            if nd < best.get(other, math.inf):
                best[other] = nd
                prev[other] = node
                heapq.heappush(heap, (nd, other))
    return None


def geodesic(layout: HouseLayout, a: Point, b: Point, blocked: Iterable[int] = ()
             ) -> float | None:
    """Length of :func:`route`, or None."""
    found = route(layout, a, b, blocked)
    return None if found is None else found[0]


def reference_length(
    layout: HouseLayout, waypoints: Sequence[tuple[Point, frozenset[int]]]
) -> float | None:
    """Length of a chain of legs; each waypoint carries the doors locked from it onwards."""
    total = 0.0
    for (a, blocked), (b, _) in zip(waypoints, waypoints[1:], strict=False):
        leg = geodesic(layout, a, b, blocked)
        if leg is None:
            return None
        total += leg
    return total


def tour(layout: HouseLayout, start: Point, points: Sequence[Point]
         ) -> tuple[float, int]:
    """The shortest walk from ``start`` through every point (in any order): its length and
    the door crossings on it (exact over orders; houses have at most 8 rooms)."""
    nodes = [start, *points]
    n = len(nodes)
    legs = [[route(layout, nodes[i], nodes[j]) for j in range(n)] for i in range(n)]
    dist = [[math.inf if leg is None else leg[0] for leg in row] for row in legs]
    full = (1 << (n - 1)) - 1
    best: dict[tuple[int, int], tuple[float, int]] = {}
    for j in range(1, n):
        leg = legs[0][j]
        best[(1 << (j - 1), j)] = (dist[0][j], len(leg[1]) if leg else 0)
    for mask in range(1, full + 1):
        for j in range(1, n):
            here = best.get((mask, j))
            if here is None:
                continue
            for k in range(1, n):
                bit = 1 << (k - 1)
                if mask & bit or legs[j][k] is None:
                    continue
                cand = (here[0] + dist[j][k], here[1] + len(legs[j][k][1]))  # type: ignore[index]
                if cand[0] < best.get((mask | bit, k), (math.inf, 0))[0]:
                    best[(mask | bit, k)] = cand
    ends = [best[(full, j)] for j in range(1, n) if (full, j) in best]
    return min(ends) if ends else (0.0, 0)
