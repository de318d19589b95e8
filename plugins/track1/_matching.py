"""Matching an agent's own ids to the truth's (the ``vision`` split, where no id is shown).

On ``vision`` the agent names things by ids of its own. Before the score reads a world model,
each of its entries is paired with at most one true thing of the same kind and category,
by position, and renamed to the true id; the scorer then runs unchanged. An entry that
pairs with nothing is renamed to an id no true thing has (``UNMATCHED``), which scores as an
unknown id does on the other splits. Room ids are not renamed: the room sign shows them.

- **objects and tools** (``objects``): same category, position within ``ITEM_RADIUS`` of
  the true position; pairs by ``scipy.optimize.linear_sum_assignment`` on the distances.
- **containers** (``containers``): same category (``type``) and room, where the room is
  given; the position is the mean of the positions of the model's objects that name the
  container as their ``receptacle``, and it must lie within ``ITEM_RADIUS`` of the true
  footprint (without one, only category and room decide, nearest first in list order).
- **doors** (``doors``): through the model's ``connections``: the door a connection names
  is the true door between the same two rooms (the doorway it stands in).

The maps follow every place that names an id: ``connections.door``, ``objects.receptacle``
(a container's), ``affordances.tool`` (an object's), and the ``tools_for`` answers
(``rename_answer``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from schemas import WorldModel
from simhost.worlds.track1 import FurnitureTruth, HouseTruth

ITEM_RADIUS = 0.75
"""Largest distance (m) at which an entry pairs with a true thing (the inventory's
``POSITION_TOLERANCE``)."""
UNMATCHED = "unmatched "
"""Prefix of the id an entry that pairs with nothing is renamed to (no true id has it)."""
_FAR = 1e6


@dataclass(frozen=True)
class IdMatch:
    """Agent id → true id, one map per kind (the model's keys as written, through ``_key``)."""

    objects: dict[Any, int] = field(default_factory=dict)
    containers: dict[Any, int] = field(default_factory=dict)
    doors: dict[Any, int] = field(default_factory=dict)


def _key(value: Any) -> Any:
    """Ids as the agent may write them (``3`` or ``"3"``) compare equal."""
    if isinstance(value, str) and value.strip().lstrip("-").isdigit():
        return int(value)
    return value


def _assign(cost: np.ndarray) -> list[tuple[int, int]]:
    """Row-column pairs of least total cost, only where the cost is feasible."""
    if cost.size == 0:
        return []
    rows, cols = linear_sum_assignment(cost)
    return [(int(r), int(c)) for r, c in zip(rows, cols, strict=True) if cost[r, c] < _FAR]


def _footprint_distance(point: tuple[float, float], f: FurnitureTruth) -> float:
    """Distance (m) from a point to a furniture's footprint (0 inside)."""
    c, s = math.cos(f.yaw), math.sin(f.yaw)
    dx, dy = point[0] - f.position[0], point[1] - f.position[1]
    u, v = c * dx + s * dy, -s * dx + c * dy
    return math.hypot(max(0.0, abs(u) - f.size[0] / 2), max(0.0, abs(v) - f.size[1] / 2))


def match(model: WorldModel, gt: HouseTruth) -> IdMatch:
    """The pairs of the model's entries with the true things (module doc)."""
    out = IdMatch()
    # objects and tools: per category, by position
    for cat in {o.category for o in model.objects if o.category is not None}:
        given = [o for o in model.objects if o.category == cat and o.position is not None]
        truth = [o for o in gt.objects if o.category == cat]
        cost = np.full((len(given), len(truth)), _FAR)
        for i, o in enumerate(given):
            assert o.position is not None
            for j, t in enumerate(truth):
                d = math.dist(o.position, t.position[:2])
                if d <= ITEM_RADIUS:
                    cost[i, j] = d
        for i, j in _assign(cost):
            out.objects.setdefault(_key(given[i].id), truth[j].id)
    # containers: per category, by room and the position of what the model puts in them
    held: dict[Any, list[tuple[float, float]]] = {}
    for o in model.objects:
        if o.receptacle is not None and o.position is not None:
            held.setdefault(_key(o.receptacle), []).append(o.position)
    for cat in {c.type for c in model.containers if c.type is not None}:
        boxes = [c for c in model.containers if c.type == cat]
        truth_boxes = [c for c in gt.containers if c.category == cat]
        cost = np.full((len(boxes), len(truth_boxes)), _FAR)
        for i, c in enumerate(boxes):
            pts = held.get(_key(c.id))
            at = (float(np.mean([p[0] for p in pts])), float(np.mean([p[1] for p in pts]))) \
                if pts else None
            for j, t in enumerate(truth_boxes):
                if c.room is not None and _key(c.room) != t.room:
                    continue
                d = 0.0 if at is None else _footprint_distance(at, t)
                if d <= ITEM_RADIUS:
                    cost[i, j] = d + 1e-3 * j  # ties: list order
        for i, j in _assign(cost):
            out.containers.setdefault(_key(boxes[i].id), truth_boxes[j].id)
    # doors: the doorway between the two rooms a connection names
    free = {}
    for d in gt.doors:
        free.setdefault(frozenset(d.rooms), []).append(d.id)
    for c in model.connections:
        if c.door is None or _key(c.door) in out.doors:
            continue
        pair = frozenset(_key(r) for r in c.rooms)
        if free.get(pair):
            out.doors[_key(c.door)] = free[pair].pop(0)
    return out


def _renamed(table: Mapping[Any, int], value: Any) -> Any:
    key = _key(value)
    return table.get(key, f"{UNMATCHED}{key}")


def rename(model: WorldModel, ids: IdMatch) -> WorldModel:
    """The model under the true ids (an unpaired entry under an ``UNMATCHED`` id)."""
    data = model.model_dump()
    for d in data["doors"]:
        d["id"] = _renamed(ids.doors, d["id"])
    for c in data["connections"]:
        if c["door"] is not None:
            c["door"] = _renamed(ids.doors, c["door"])
    for c in data["containers"]:
        c["id"] = _renamed(ids.containers, c["id"])
    for o in data["objects"]:
        o["id"] = _renamed(ids.objects, o["id"])
        if o["receptacle"] is not None:
            key = _key(o["receptacle"])
            o["receptacle"] = ids.containers.get(key, f"{UNMATCHED}{key}")
    for a in data["affordances"]:
        a["tool"] = _renamed(ids.objects, a["tool"])
    return WorldModel.model_validate(data)


def matched(model: WorldModel | None, gt: HouseTruth | None) -> WorldModel | None:
    """``model`` under the true ids it matches in ``gt`` (None stays None)."""
    if model is None or gt is None:
        return model
    return rename(model, match(model, gt))


def rename_answer(answer: Any, objects: Mapping[Any, int]) -> Any:
    """An answer that lists the agent's tool ids (``tools_for``) under the true ids; an id
    that pairs with nothing becomes a negative id (no true id), a wrong answer as an unknown
    id is on the other splits."""
    if not isinstance(answer, list):
        return answer
    return [objects.get(_key(a), -1 - k) for k, a in enumerate(answer)]
