"""Furnishing a planned house: furniture against walls, a free-space check, items on slots.

Furniture stands with its back to a wall, clear of doorways, with a collision-free access
pose in front of it; a free-space flood fill (robot radius and open door panels included)
from the start checks that every access pose and both sides of every doorway are reachable,
else the furniture is drawn again from the same generator.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ._catalogue import AFFORDANCE_EFFECTS, AFFORDANCES, ItemSpec
from ._errors import LayoutError
from ._layout import Furniture, HouseParams, Item, Room, door_panel_distance, door_swing_distance
from ._plan import (
    ACCESS_DISTANCE,
    CLEARANCE,
    RES,
    ROBOT_RADIUS,
    WALL_T,
    Piece,
    Plan,
    Rect,
    centre,
    overlap,
)


def _door_zones(plan: Plan, room: int) -> list[Rect]:
    """Furniture-free rectangles by the room's doorways: 1.3 m deep, 1.8 m on the side the
    door swings into (so a robot can stand clear of the swing and still reach the door)."""
    zones = []
    for d in plan.doors:
        if room not in d["rooms"]:
            continue
        g0, g1 = d["gap"]
        line = d["line"]
        depth = 1.8 if d["swing_room"] == room else 1.3
        cx, cy = centre(plan.bounds[room])
        side = 1.0 if (cx if d["vertical"] else cy) > line else -1.0
        near, far = sorted((line - side * 0.1, line + side * depth))
        if d["vertical"]:
            zones.append((near, g0 - 0.4, far, g1 + 0.4))
        else:
            zones.append((g0 - 0.4, near, g1 + 0.4, far))
    return zones


def place_furniture(
    rng: np.random.Generator, params: HouseParams, plan: Plan
) -> list[Piece] | None:
    pieces: list[Piece] = []
    for room, room_type in enumerate(plan.types):
        mix = params.room_furniture.get(room_type)
        if mix is None:
            continue
        k = int(rng.integers(mix.optional_count[0], mix.optional_count[1] + 1))
        k += params.furniture_extra
        optional = [mix.optional[i] for i in rng.permutation(len(mix.optional))][:k]
        zones = _door_zones(plan, room)
        placed: list[Piece] = []
        for n_required, cat in enumerate(list(mix.required) + optional):
            piece = None
            for _ in range(40):
                piece = _try_piece(rng, params, plan, room, cat, placed, zones)
                if piece is not None:
                    break
            if piece is not None:
                placed.append(piece)
            elif n_required < len(mix.required):
                return None
        pieces.extend(placed)
    return pieces


def _try_piece(
    rng: np.random.Generator,
    params: HouseParams,
    plan: Plan,
    room: int,
    cat: str,
    placed: list[Piece],
    zones: list[Rect],
) -> Piece | None:
    spec = params.furniture_spec(cat)
    w, d, h = spec.size
    x0, y0, x1, y1 = plan.bounds[room]
    ix0, iy0, ix1, iy1 = x0 + WALL_T / 2, y0 + WALL_T / 2, x1 - WALL_T / 2, y1 - WALL_T / 2
    side = int(rng.integers(4))
    u = float(rng.random())
    if side in (0, 1):
        span = (ix0 + w / 2 + 0.05, ix1 - w / 2 - 0.05)
        along = round(span[0] + u * (span[1] - span[0]), 2)
        y = iy0 + d / 2 + 0.01 if side == 0 else iy1 - d / 2 - 0.01
        pos, yaw = (along, round(y, 3)), (0.0 if side == 0 else math.pi)
        rect = (along - w / 2, y - d / 2, along + w / 2, y + d / 2)
    else:
        span = (iy0 + w / 2 + 0.05, iy1 - w / 2 - 0.05)
        along = round(span[0] + u * (span[1] - span[0]), 2)
        x = ix0 + d / 2 + 0.01 if side == 2 else ix1 - d / 2 - 0.01
        pos, yaw = (round(x, 3), along), (-math.pi / 2 if side == 2 else math.pi / 2)
        rect = (x - d / 2, along - w / 2, x + d / 2, along + w / 2)
    if span[1] < span[0]:
        return None
    fx, fy = -math.sin(yaw), math.cos(yaw)
    reach = d / 2 + ACCESS_DISTANCE
    access = (
        round(pos[0] + fx * reach, 3),
        round(pos[1] + fy * reach, 3),
        _wrap(yaw - math.pi / 2),
    )
    front = (pos[0] + fx * d / 2, pos[1] + fy * d / 2)
    far = (pos[0] + fx * (d / 2 + 0.8), pos[1] + fy * (d / 2 + 0.8))
    if side in (0, 1):
        keep = (pos[0] - w / 2, min(front[1], far[1]), pos[0] + w / 2, max(front[1], far[1]))
    else:
        keep = (min(front[0], far[0]), pos[1] - w / 2, max(front[0], far[0]), pos[1] + w / 2)
    m = ROBOT_RADIUS + CLEARANCE
    if not (ix0 + m <= access[0] <= ix1 - m and iy0 + m <= access[1] <= iy1 - m):
        return None
    if any(overlap(rect, z) for z in zones):
        return None
    for door in plan.doors:
        if room in door["rooms"] and _door_distance(door, access[0], access[1]) < m + 0.05:
            return None
    for p in placed:
        if overlap(rect, p.rect, 0.1) or overlap(rect, p.keep_out) or overlap(keep, p.rect):
            return None
    return Piece(cat, room, pos, yaw, spec.size, spec.opening, rect, keep, access)


def _door_distance(door: dict, x: float, y: float) -> float:
    """Distance from a point to everything a door's panel can occupy (closed, open, between)."""
    yaw = door["yaw"]
    sign = 1.0 if door["open_angle"] > 0 else -1.0
    normal = (-math.sin(yaw) * sign, math.cos(yaw) * sign)
    swing = door_swing_distance(door["hinge"], yaw, normal, door["width"], x, y)
    return min(swing, door_panel_distance(door["hinge"], yaw, door["width"], x, y))


def _open_panel(door: dict) -> Rect:
    yaw = door["yaw"]
    sign = 1.0 if door["open_angle"] > 0 else -1.0
    nx, ny = -math.sin(yaw) * sign, math.cos(yaw) * sign
    (hx, hy), w, t = door["hinge"], door["width"], 0.025
    ex, ey = hx + nx * w, hy + ny * w
    return (min(hx, ex) - t, min(hy, ey) - t, max(hx, ex) + t, max(hy, ey) + t)


def _wrap(angle: float) -> float:
    return round(math.atan2(math.sin(angle), math.cos(angle)), 6)


def _free_space(plan: Plan, pieces: list[Piece]) -> tuple[np.ndarray, float]:
    width, height = sum(plan.col_widths), sum(plan.row_heights)
    nx, ny = int(math.ceil(width / RES)), int(math.ceil(height / RES))
    free = np.zeros((ny, nx), dtype=bool)
    m = ROBOT_RADIUS + CLEARANCE

    def paint(rect: Rect, value: bool) -> None:
        i0 = max(0, int(math.ceil(rect[0] / RES - 0.5)))
        i1 = min(nx, int(math.floor(rect[2] / RES - 0.5)) + 1)
        j0 = max(0, int(math.ceil(rect[1] / RES - 0.5)))
        j1 = min(ny, int(math.floor(rect[3] / RES - 0.5)) + 1)
        if i1 > i0 and j1 > j0:
            free[j0:j1, i0:i1] = value

    for x0, y0, x1, y1 in plan.bounds:
        paint(
            (x0 + WALL_T / 2 + m, y0 + WALL_T / 2 + m, x1 - WALL_T / 2 - m, y1 - WALL_T / 2 - m),
            True,
        )
    for d in plan.doors:
        g0, g1 = d["gap"]
        across = WALL_T / 2 + m + RES
        if d["vertical"]:
            paint((d["line"] - across, g0 + m, d["line"] + across, g1 - m), True)
        else:
            paint((g0 + m, d["line"] - across, g1 - m, d["line"] + across), True)
    for r in [p.rect for p in pieces] + [_open_panel(d) for d in plan.doors]:
        paint((r[0] - m, r[1] - m, r[2] + m, r[3] + m), False)
    return free, RES


def _flood(free: np.ndarray, seed: tuple[int, int]) -> np.ndarray:
    reach = np.zeros_like(free)
    reach[seed] = True
    while True:
        grown = reach.copy()
        grown[1:, :] |= reach[:-1, :]
        grown[:-1, :] |= reach[1:, :]
        grown[:, 1:] |= reach[:, :-1]
        grown[:, :-1] |= reach[:, 1:]
        grown &= free
        if np.array_equal(grown, reach):
            return reach
        reach = grown


def check_free_space(
    rng: np.random.Generator, plan: Plan, pieces: list[Piece]
) -> tuple[float, float, float] | None:
    free, res = _free_space(plan, pieces)
    start_room = plan.types.index("hallway" if "hallway" in plan.types else "living_room")
    x0, y0, x1, y1 = plan.bounds[start_room]
    cx, cy = centre(plan.bounds[start_room])
    jj, ii = np.nonzero(free)
    px, py = (ii + 0.5) * res, (jj + 0.5) * res
    inside = (px > x0) & (px < x1) & (py > y0) & (py < y1)
    if not inside.any():
        return None
    dist = np.where(inside, (px - cx) ** 2 + (py - cy) ** 2, np.inf)
    k = int(np.argmin(dist))
    reach = _flood(free, (int(jj[k]), int(ii[k])))
    points = [p.access[:2] for p in pieces]
    for d in plan.doors:
        g0, g1 = d["gap"]
        mid = (g0 + g1) / 2
        for off in (-0.7, 0.7):
            points.append((d["line"] + off, mid) if d["vertical"] else (mid, d["line"] + off))
    for x, y in points:
        i, j = int(x / res), int(y / res)
        if not reach[min(j, reach.shape[0] - 1), min(i, reach.shape[1] - 1)]:
            return None
    yaw = round(float(rng.uniform(-math.pi, math.pi)), 3)
    return (round(float(px[k]), 3), round(float(py[k]), 3), yaw)


class _Slots:
    def __init__(self, furniture: list[Furniture]) -> None:
        self.free = {f.id: list(range(f.slots)) for f in furniture}
        self.used: set[tuple[str, str]] = set()

    def receptacles(
        self, furniture: list[Furniture], room: int | None, spec: ItemSpec
    ) -> list[Furniture]:
        return [
            f
            for f in furniture
            if (room is None or f.room == room)
            and f.category in spec.receptacles
            and self.free[f.id]
        ]


def place_items(
    rng: np.random.Generator,
    params: HouseParams,
    rooms: tuple[Room, ...],
    furniture: list[Furniture],
    next_id: int,
) -> list[Item]:
    slots = _Slots(furniture)
    items: list[Item] = []
    objects = [s for s in params.items if not s.affordances]

    def place(spec: ItemSpec, room: int | None, kind: str, twin: str | None = None) -> bool:
        if twin is None:
            colours = [c for c in spec.colours if (spec.category, c) not in slots.used]
        else:
            colours = [twin]
        recs = slots.receptacles(furniture, room, spec)
        if not colours or not recs:
            return False
        inside = [f for f in recs if f.kind == "container"]
        surface = [f for f in recs if f.kind == "furniture"]
        pool = (
            inside if inside and (not surface or rng.random() < params.p_in_container) else surface
        )
        rec = pool[int(rng.integers(len(pool)))]
        slot = slots.free[rec.id].pop(int(rng.integers(len(slots.free[rec.id]))))
        colour = colours[int(rng.integers(len(colours)))]
        slots.used.add((spec.category, colour))
        items.append(
            Item(
                id=next_id + len(items),
                kind=kind,
                category=spec.category,
                colour=colour,
                shape=spec.shape,
                size=spec.size,
                half_height=spec.half_height,
                affordances=spec.affordances,
                receptacle=rec.id,
                slot=slot,
                initial_state=spec.states[0] if spec.states else "none",
            )
        )
        return True

    for room in rooms:
        k = int(rng.integers(params.objects_per_room[0], params.objects_per_room[1] + 1))
        liked = params.room_items.get(room.type, ())
        weights = np.array([params.room_item_weight if s.category in liked else 1.0
                            for s in objects])
        for _ in range(k):
            if liked:
                order = rng.choice(len(objects), size=len(objects), replace=False,
                                   p=weights / weights.sum()).tolist()
            else:
                order = rng.permutation(len(objects)).tolist()
            for i in order:
                if place(objects[i], room.id, "object"):
                    break
    for aff in AFFORDANCES:
        cats = [s for s in params.items if aff in s.affordances]
        if not cats:
            continue
        order = rng.permutation(len(cats)).tolist()
        used_rooms: set[int] = set()
        for k in range(params.tools_per_affordance):
            spec = cats[order[k % len(cats)]]
            room_order = [rooms[i].id for i in rng.permutation(len(rooms))]
            room_order.sort(key=lambda r: r in used_rooms)
            for room_id in room_order:
                if place(spec, room_id, "tool"):
                    used_rooms.add(room_id)
                    break
            else:
                raise LayoutError(f"no free receptacle for tool {spec.category!r}")
    for before, _after in (AFFORDANCE_EFFECTS[a] for a in AFFORDANCES):
        if any(i.initial_state == before for i in items):
            continue
        specs = [s for s in objects if s.states and s.states[0] == before]
        for i in rng.permutation(len(specs)).tolist():
            if place(specs[i], None, "object"):
                break
    if params.distractors[1] > 0:
        _add_twins(rng, params, rooms, furniture, items, place)
    return items


def _add_twins(
    rng: np.random.Generator,
    params: HouseParams,
    rooms: tuple[Room, ...],
    furniture: list[Furniture],
    items: list[Item],
    place: Callable[[ItemSpec, int | None, str, str | None], bool],
) -> None:
    """Look-alikes: objects of the category and colour of one already placed, each in a room
    where neither it nor another look-alike of it is."""
    where = {f.id: f.room for f in furniture}
    specs = {s.category: s for s in params.items}
    n = int(rng.integers(params.distractors[0], params.distractors[1] + 1))
    for _ in range(n):
        originals = [i for i in items if i.kind == "object"]
        order = rng.permutation(len(originals)).tolist()
        for k in order:
            src = originals[k]
            taken = {where[i.receptacle] for i in items
                     if (i.category, i.colour) == (src.category, src.colour)}
            others = [r.id for r in rooms if r.id not in taken]
            placed = False
            for j in rng.permutation(len(others)).tolist():
                if place(specs[src.category], others[j], "object", src.colour):
                    placed = True
                    break
            if placed:
                break
