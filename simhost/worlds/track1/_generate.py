"""The procedural house generator (pure Python and numpy; one seeded generator only).

Rooms are rectangles of one or two cells of a 2x2..3x5 grid with random column widths and
row heights. The door graph is **2-edge-connected**: every room pair that shares a wall is a
candidate doorway; doors are dropped at random only while no door becomes a bridge. So
locking any one door still leaves every room reachable from every other room (in particular
from the robot's start), which is how every door-lock exception keeps a recoverable path.
Furnishing is in ``_furnish``.
"""

from __future__ import annotations

import math

import numpy as np

from ._catalogue import MAX_IDS, REQUIRED_ROOMS
from ._errors import LayoutError
from ._furnish import check_free_space, place_furniture, place_items
from ._graph import Edge, is_two_edge_connected
from ._layout import Door, Furniture, HouseLayout, HouseParams, Room, Wall, slot_count
from ._plan import WALL_T, Piece, Plan, Rect, Segment, centre


def generate_house(seed: int, *, params: HouseParams | None = None) -> HouseLayout:
    """Generate a house from a seed. Same seed and params, same layout, always.

    Args:
        seed: a non-negative integer; the only source of randomness
            (``numpy.random.default_rng(seed)``).
        params: generator parameters (default ``HouseParams()``: the standard split).

    Returns:
        The frozen layout.

    Raises:
        LayoutError: bad seed, or no valid house after many attempts (a parameter pack
            whose furniture cannot fit its rooms).
    """
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise LayoutError(f"seed must be a non-negative int, got {seed!r}")
    params = params or HouseParams()
    rng = np.random.default_rng(int(seed))
    for _ in range(40):
        plan = _plan_rooms(rng, params)
        if plan is None:
            continue
        for _ in range(25):
            pieces = place_furniture(rng, params, plan)
            if pieces is None:
                continue
            start = check_free_space(rng, plan, pieces)
            if start is not None:
                return _assemble(int(seed), rng, params, plan, pieces, start)
    raise LayoutError(
        f"no valid house for seed {seed} after many attempts; check that the parameter "
        "pack's furniture fits rooms of the given cell_size"
    )


def _grid_options(n: int) -> list[tuple[int, int]]:
    out = []
    for rows in (2, 3):
        for cols in (2, 3, 4, 5):
            extra = rows * cols - n
            if 0 <= extra <= 2:
                out.append((rows, cols))
    return out


def _plan_rooms(rng: np.random.Generator, params: HouseParams) -> Plan | None:
    n = int(rng.integers(params.rooms[0], params.rooms[1] + 1))
    options = _grid_options(n)
    rows, cols = options[int(rng.integers(len(options)))]
    lo, hi = params.cell_size
    widths = [round(float(v), 1) for v in rng.uniform(lo, hi, cols)]
    heights = [round(float(v), 1) for v in rng.uniform(lo, hi, rows)]
    groups: list[list[tuple[int, int]]] = [[(r, c)] for r in range(rows) for c in range(cols)]
    for _ in range(rows * cols - n):
        single = [g[0] for g in groups if len(g) == 1]
        pairs = sorted(
            (a, b)
            for a in single
            for b in single
            if a < b and abs(a[0] - b[0]) + abs(a[1] - b[1]) == 1
        )
        if not pairs:
            return None
        a, b = pairs[int(rng.integers(len(pairs)))]
        groups = [g for g in groups if g not in ([a], [b])] + [[a, b]]
    groups.sort(key=min)
    xs = np.concatenate([[0.0], np.cumsum(widths)]).round(6).tolist()
    ys = np.concatenate([[0.0], np.cumsum(heights)]).round(6).tolist()
    bounds: list[Rect] = []
    for g in groups:
        r0, r1 = min(c[0] for c in g), max(c[0] for c in g)
        c0, c1 = min(c[1] for c in g), max(c[1] for c in g)
        bounds.append((xs[c0], ys[r0], xs[c1 + 1], ys[r1 + 1]))
    plan = Plan(widths, heights, groups, bounds)
    owner = {cell: i for i, g in enumerate(groups) for cell in g}
    for r in range(rows):
        for c in range(-1, cols):
            a, b = owner.get((r, c)), owner.get((r, c + 1))
            if a != b:
                rooms = tuple(x for x in (a, b) if x is not None)
                plan.segments.append(Segment(rooms, True, xs[c + 1], ys[r], ys[r + 1]))
    for c in range(cols):
        for r in range(-1, rows):
            a, b = owner.get((r, c)), owner.get((r + 1, c))
            if a != b:
                rooms = tuple(x for x in (a, b) if x is not None)
                plan.segments.append(Segment(rooms, False, ys[r + 1], xs[c], xs[c + 1]))
    pairs = sorted({tuple(sorted(s.rooms)) for s in plan.segments if len(s.rooms) == 2})
    nodes = list(range(n))
    edges: list[Edge] = [(a, b, i) for i, (a, b) in enumerate(pairs)]
    if not is_two_edge_connected(nodes, edges):
        return None
    for i in rng.permutation(len(edges)).tolist():
        if rng.random() < params.p_keep_door:
            continue
        trial = [e for e in edges if e[2] != i]
        if is_two_edge_connected(nodes, trial):
            edges = trial
    plan.pairs = [(a, b) for a, b, _ in edges]
    plan.types = _room_types(rng, params, n, plan.pairs)
    for a, b in plan.pairs:
        door = _make_door(rng, params, plan, a, b)
        if door is None:
            return None
        plan.doors.append(door)
    return plan


def _room_types(rng: np.random.Generator, params: HouseParams, n: int, pairs: list) -> list[str]:
    extra = [params.optional_rooms[i] for i in rng.permutation(len(params.optional_rooms))]
    wanted = list(REQUIRED_ROOMS) + extra[: n - len(REQUIRED_ROOMS)]
    degree = [sum(r in p for p in pairs) for r in range(n)]
    types: list[str | None] = [None] * n
    free = list(range(n))

    def take(type_name: str, pick: int) -> None:
        best = [r for r in free if degree[r] == pick]
        room = best[int(rng.integers(len(best)))]
        types[room] = type_name
        free.remove(room)
        wanted.remove(type_name)

    if "hallway" in wanted:
        take("hallway", max(degree[r] for r in free))
    take("storage", min(degree[r] for r in free))
    order = rng.permutation(len(wanted)).tolist()
    for room, k in zip(free, order, strict=True):
        types[room] = wanted[k]
    return [t for t in types if t is not None]


def _make_door(
    rng: np.random.Generator, params: HouseParams, plan: Plan, a: int, b: int
) -> dict | None:
    segs = [s for s in plan.segments if sorted(s.rooms) == [a, b]]
    seg = segs[int(rng.integers(len(segs)))]
    width = params.door_width
    lo, hi = seg.s0 + 0.8, seg.s1 - 0.8 - width
    if hi < lo:
        return None
    g0 = round(float(rng.uniform(lo, hi)) / 0.05) * 0.05
    hinge = (seg.line, g0) if seg.vertical else (g0, seg.line)
    yaw = math.pi / 2 if seg.vertical else 0.0
    swing = (a, b)[int(rng.integers(2))]
    mid = (hinge[0] + math.cos(yaw) * width / 2, hinge[1] + math.sin(yaw) * width / 2)
    sx, sy = centre(plan.bounds[swing])
    left = (-math.sin(yaw), math.cos(yaw))
    side = (sx - mid[0]) * left[0] + (sy - mid[1]) * left[1]
    state = "open" if rng.random() < params.p_door_open else "closed"
    seg.gaps.append((g0, g0 + width))
    return {
        "rooms": (a, b),
        "hinge": (round(hinge[0], 3), round(hinge[1], 3)),
        "yaw": yaw,
        "width": width,
        "swing_room": swing,
        "state": state,
        "open_angle": math.pi / 2 if side > 0 else -math.pi / 2,
        "vertical": seg.vertical,
        "line": seg.line,
        "gap": (g0, g0 + width),
    }


def _walls(plan: Plan) -> list[Wall]:
    out = []
    for seg in plan.segments:
        cuts = sorted(seg.gaps)
        spans, at = [], seg.s0 - WALL_T / 2
        for g0, g1 in cuts:
            spans.append((at, g0))
            at = g1
        spans.append((at, seg.s1 + WALL_T / 2))
        for s0, s1 in spans:
            mid, half = round((s0 + s1) / 2, 4), round((s1 - s0) / 2, 4)
            if seg.vertical:
                out.append(Wall(centre=(seg.line, mid), half=(WALL_T / 2, half)))
            else:
                out.append(Wall(centre=(mid, seg.line), half=(half, WALL_T / 2)))
    return out


def _assemble(
    seed: int,
    rng: np.random.Generator,
    params: HouseParams,
    plan: Plan,
    pieces: list[Piece],
    start: tuple[float, float, float],
) -> HouseLayout:
    rooms = tuple(
        Room(id=i, type=t, cells=tuple(sorted(plan.cells[i])), bounds=plan.bounds[i])
        for i, t in enumerate(plan.types)
    )
    next_id = 1
    doors = []
    for d in plan.doors:
        doors.append(
            Door(
                id=next_id,
                rooms=d["rooms"],
                hinge=d["hinge"],
                yaw=d["yaw"],
                width=d["width"],
                swing_room=d["swing_room"],
                open_angle=d["open_angle"],
                initial_state=d["state"],
            )
        )
        next_id += 1
    furniture = []
    for p in pieces:
        spec = params.furniture_spec(p.category)
        if p.opening != "none":
            state = "open" if rng.random() < params.p_container_open else "closed"
        elif spec.wipeable:
            state = "dirty" if rng.random() < params.p_dirty else "clean"
        else:
            state = "none"
        furniture.append(
            Furniture(
                id=next_id,
                kind="furniture" if p.opening == "none" else "container",
                category=p.category,
                room=p.room,
                pos=p.pos,
                yaw=p.yaw,
                size=p.size,
                opening=p.opening,
                initial_state=state,
                access=p.access,
                slots=slot_count(p.size, p.opening),
            )
        )
        next_id += 1
    wipeable = [
        f for f in furniture if f.opening == "none" and f.initial_state in ("dirty", "clean")
    ]
    if wipeable and not any(f.initial_state == "dirty" for f in wipeable):
        pick = wipeable[int(rng.integers(len(wipeable)))]
        furniture[furniture.index(pick)] = pick.model_copy(update={"initial_state": "dirty"})
    items = place_items(rng, params, rooms, furniture, next_id)
    if items and items[-1].id >= MAX_IDS:
        raise LayoutError(f"house has {items[-1].id} entities; ids must stay below {MAX_IDS}")
    return HouseLayout(
        seed=seed,
        params_digest=params.digest(),
        col_widths=tuple(plan.col_widths),
        row_heights=tuple(plan.row_heights),
        rooms=rooms,
        doors=tuple(doors),
        walls=tuple(_walls(plan)),
        furniture=tuple(furniture),
        items=tuple(items),
        start=start,
        start_room=plan.types.index("hallway" if "hallway" in plan.types else "living_room"),
        backup_room=plan.types.index("storage"),
    )
