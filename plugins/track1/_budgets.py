"""Step budgets derived from an episode's ground truth, so that results do not depend on the
machine and exhaustive search does not fit (they apply besides the wall-clock budgets).

A reference route is converted to steps as a robot drives it: ``metres / max_forward``
forward steps, ``TURN_STEPS`` per leg to turn (up to 135 degrees), ``DOOR_STEPS`` per
doorway crossed (a door may need opening), and one step per primitive of the task.

- exploration: ``EXPLORATION_FACTOR`` × an oracle's tour of every room: the shortest walk
  from the start through every room's centre (an oracle knows the house: it needs no
  look around); an explorer must choose what to look at.
- execution: ``EXECUTION_FACTOR`` × the task's reference route (through the true access
  poses of what it moves and where, goal after goal), from the farthest room's centre (the
  agent may end exploration anywhere), with the planned exception's worst case included
  (the door on the route locked, the object moved to the farthest backup place, the
  farthest substitute tool or container).
- planning: no step cap (nothing moves; the stage ends with the plan).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

from plugins.track1._paths import Point, route, tour
from plugins.track1._types import Goal, Track1Scenario
from simhost.worlds.track1 import HouseLayout, HouseTruth

EXPLORATION_FACTOR = 1.3
EXECUTION_FACTOR = 2.0
TURN_STEPS = 3
DOOR_STEPS = 2


BACKUP_CONTAINERS = ("cabinet", "drawer")
"""Closed storage outside the storage room, where a relocated item may be put away."""
BACKUP_FALLBACK = ("shelf",)
"""Where it goes when no closed storage has room: a shelf elsewhere."""


def backup_places(truth: HouseTruth, avoid_rooms: Iterable[int],
                  avoid: Iterable[int] = ()) -> tuple[list[int], list[int]]:
    """Receptacles where a relocated object may end up (the backup areas, where things are
    put away), in two tiers: everything in the storage room and cabinets and drawers
    elsewhere (shut after, ``_exceptions``); else, when none of those can take it, a shelf
    elsewhere. Never in ``avoid_rooms``, never one of ``avoid`` (the task's destinations: a
    move must not do the task)."""
    rooms, ids = set(avoid_rooms), set(avoid)
    usable = [f for f in (*truth.furniture, *truth.containers)
              if f.room not in rooms and f.id not in ids and f.state != "unavailable"]
    first = [f.id for f in usable
             if f.room == truth.backup_room or f.category in BACKUP_CONTAINERS]
    return first, [f.id for f in usable if f.id not in first and f.category in BACKUP_FALLBACK]


def _access(truth: HouseTruth, entity: int) -> Point:
    rec = truth.receptacle(entity)
    if rec is None:
        obj = truth.object(entity)
        assert obj is not None, f"no entity {entity} in the truth"
        rec = truth.receptacle(obj.receptacle)
        assert rec is not None
    return (rec.access[0], rec.access[1])


def goal_points(truth: HouseTruth, goals: Sequence[Goal], start: Point,
                swap: dict[tuple[int, str], Point] | None = None) -> list[Point]:
    """Waypoints of the goals done in order: where each fetched thing is (its receptacle's
    access pose, or where the previous goal left it), then its destination's access pose.
    ``swap[(goal index, "from" | "to")]`` replaces a point (a substitute, a backup place);
    ``swap[(goal index, "via")]`` is visited before the fetched thing (where it was)."""
    swap = swap or {}
    where: dict[int, Point] = {}
    points = [start]
    for k, g in enumerate(goals):
        src = swap.get((k, "from")) or where.get(g.fetched) or _access(truth, g.fetched)
        dst = swap.get((k, "to")) or _access(truth, g.destination)
        if (k, "via") in swap:
            points.append(swap[(k, "via")])
        points += [src, dst]
        where[g.fetched] = dst
    return points


def length(layout: HouseLayout, points: Sequence[Point], blocked: Iterable[int] = ()
           ) -> tuple[float, int] | None:
    """Length and door crossings of a chain of legs, or None when a leg is closed."""
    total, doors = 0.0, 0
    for a, b in zip(points, points[1:], strict=False):
        leg = route(layout, a, b, blocked)
        if leg is None:
            return None
        total, doors = total + leg[0], doors + len(leg[1])
    return total, doors


def _steps(metres: float, legs: int, doors: int, extra: int, max_forward: float) -> int:
    return math.ceil(metres / max_forward) + TURN_STEPS * legs + DOOR_STEPS * doors + extra


def _actions(goals: Sequence[Goal]) -> int:
    return sum(3 if g.container else 2 for g in goals)


def exploration_steps(layout: HouseLayout, truth: HouseTruth, max_forward: float) -> int:
    """The exploration budget (steps)."""
    metres, doors = tour(layout, layout.start[:2], [r.centre for r in truth.rooms])
    return math.ceil(EXPLORATION_FACTOR * _steps(metres, len(truth.rooms), doors, 0, max_forward))


def _worst_case(layout: HouseLayout, truth: HouseTruth, spec: Track1Scenario,
                start: Point) -> tuple[float, int, int]:
    """The longest reference route from ``start`` the planned exception can force:
    (metres, doors, legs)."""
    goals = spec.task.goals
    variants: list[tuple[list[Point], tuple[int, ...]]] = [(goal_points(truth, goals, start), ())]
    exc = spec.exception
    if exc is not None:
        g = goals[exc.goal]
        if exc.type == "door_lock":
            base = goal_points(truth, goals, start)
            crossed = {d for a, b in zip(base, base[1:], strict=False)
                       for d in (route(layout, a, b) or (0.0, ()))[1]}
            variants += [(base, (d,)) for d in sorted(crossed)]
        elif exc.type == "object_relocation":
            obj = truth.object(g.fetched)
            assert obj is not None
            ends = {x for goal in goals for x in (goal.destination, *goal.substitutes)}
            for place in (p for tier in backup_places(truth, (obj.room,), ends) for p in tier):
                swap = {(exc.goal, "via"): _access(truth, g.fetched),
                        (exc.goal, "from"): _access(truth, place)}
                variants.append((goal_points(truth, goals, start, swap), ()))
        else:
            end = "from" if exc.type == "tool_substitution" else "to"
            for sub in g.substitutes:
                swap = {(exc.goal, end): _access(truth, sub)}
                variants.append((goal_points(truth, goals, start, swap), ()))
    worst = (0.0, 0, 0)
    for points, blocked in variants:
        found = length(layout, points, blocked)
        if found is not None and found[0] > worst[0]:
            worst = (found[0], found[1], len(points) - 1)
    return worst


def execution_steps(layout: HouseLayout, truth: HouseTruth, spec: Track1Scenario,
                    max_forward: float) -> int:
    """The execution budget (steps)."""
    starts = [layout.start[:2], *(r.centre for r in truth.rooms)]
    worst = 0
    for start in starts:
        metres, doors, legs = _worst_case(layout, truth, spec, start)
        worst = max(worst, _steps(metres, legs, doors, _actions(spec.task.goals), max_forward))
    return math.ceil(EXECUTION_FACTOR * worst)
