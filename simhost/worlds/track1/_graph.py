"""Room-graph algorithms (pure Python; rooms are nodes, doors are edges)."""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Sequence

Edge = tuple[int, int, int]
"""(room_a, room_b, door_id)."""


def _adjacency(nodes: Iterable[int], edges: Iterable[Edge], blocked: set[int]) -> dict:
    adj: dict[int, list[tuple[int, int]]] = {n: [] for n in nodes}
    for a, b, door in edges:
        if door in blocked:
            continue
        adj[a].append((b, door))
        adj[b].append((a, door))
    for n in adj:
        adj[n].sort()
    return adj


def shortest_room_path(
    nodes: Iterable[int], edges: Sequence[Edge], start: int, goal: int, blocked: Iterable[int] = ()
) -> list[int]:
    """Fewest-doors room path from start to goal (both included), or [] when there is none.

    Ties break towards lower room ids, so the answer is deterministic.
    """
    adj = _adjacency(nodes, edges, set(blocked))
    if start not in adj or goal not in adj:
        return []
    prev: dict[int, int] = {start: start}
    queue = deque([start])
    while queue:
        node = queue.popleft()
        if node == goal:
            break
        for nxt, _door in adj[node]:
            if nxt not in prev:
                prev[nxt] = node
                queue.append(nxt)
    if goal not in prev:
        return []
    path = [goal]
    while path[-1] != start:
        path.append(prev[path[-1]])
    return path[::-1]


def doors_on_path(
    edges: Sequence[Edge], path: Sequence[int], blocked: Iterable[int] = ()
) -> list[int]:
    """The door ids crossed by a room path (lowest door id where two doors join a pair)."""
    skip = set(blocked)
    out = []
    for a, b in zip(path, path[1:], strict=False):
        doors = sorted(d for x, y, d in edges if {x, y} == {a, b} and d not in skip)
        if not doors:
            raise ValueError(f"rooms {a} and {b} share no usable door")
        out.append(doors[0])
    return out


def reachable(
    nodes: Iterable[int], edges: Sequence[Edge], start: int, blocked: Iterable[int] = ()
) -> set[int]:
    """Rooms reachable from start without crossing a blocked door."""
    adj = _adjacency(nodes, edges, set(blocked))
    seen = {start}
    queue = deque([start])
    while queue:
        for nxt, _door in adj[queue.popleft()]:
            if nxt not in seen:
                seen.add(nxt)
                queue.append(nxt)
    return seen


def is_connected(nodes: Sequence[int], edges: Sequence[Edge], blocked: Iterable[int] = ()) -> bool:
    """True when every room reaches every other room."""
    return not nodes or len(reachable(nodes, edges, nodes[0], blocked)) == len(nodes)


def bridges(nodes: Sequence[int], edges: Sequence[Edge]) -> list[int]:
    """Doors whose locking would disconnect the graph (brute force; graphs are tiny)."""
    return [door for _a, _b, door in edges if not is_connected(nodes, edges, blocked=[door])]


def is_two_edge_connected(nodes: Sequence[int], edges: Sequence[Edge]) -> bool:
    """Connected, and still connected after removing any one edge."""
    return is_connected(nodes, edges) and not bridges(nodes, edges)


def has_cycle(nodes: Sequence[int], edges: Sequence[Edge]) -> bool:
    """True when the (multi)graph has a cycle."""
    parent = {n: n for n in nodes}

    def find(n: int) -> int:
        while parent[n] != n:
            parent[n] = parent[parent[n]]
            n = parent[n]
        return n

    for a, b, _door in edges:
        ra, rb = find(a), find(b)
        if ra == rb:
            return True
        parent[ra] = rb
    return False
