"""Queries about the house, asked at the start of planning and graded against the ground
truth at the end of exploration ("queryable" model). The one owner of queries: planning
them, showing them to the agent, their truth and their grading.

The scenario draws the queries from the whole house, seen or not, and asks them by
description; an instance id is shown only when the agent's detections reported it during
exploration (an undiscovered id is never revealed). A query left unanswered, or answered
``"unknown"``, scores 0 (never less). Kinds and answers:

- ``object_room``: "Which room (id) is the red mug in?" → a room id.
- ``door_state``: "Is the door between room 0 (the hallway) and room 2 (the kitchen) open,
  closed or locked?" → ``open`` | ``closed`` | ``locked``.
- ``room_neighbours``: "Which rooms (ids) share a doorway with room 2 (the kitchen)?" → a
  list of room ids (F1).
- ``container_state``: "Is the fridge in room 2 (the kitchen) open, closed or
  unavailable?" → ``open`` | ``closed`` | ``unavailable``.
- ``tools_for``: "Which tools (ids) can wipe?" → a list of tool ids (F1).
- ``object_count``: "How many mugs are there in the house?" → an integer (1 − relative
  error, floor 0).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from plugins.track1._language import words
from plugins.track1._types import GradedQuery, Query, QueryKind
from simhost.worlds.track1 import AFFORDANCES, HouseTruth

QUERY_PLAN: tuple[tuple[QueryKind, int], ...] = (
    ("object_room", 3), ("door_state", 2), ("room_neighbours", 2), ("container_state", 1),
    ("tools_for", 1), ("object_count", 1))
"""How many queries of each kind an episode asks (fewer when the house has too few)."""
ID_FIELD = {"object_room": "object", "door_state": "door", "container_state": "container"}
"""The field that carries the subject's instance id when the agent has seen it."""


def _room(truth: HouseTruth, room: int) -> str:
    return f"room {room} (the {words(truth.room_type(room))})"


def _candidates(truth: HouseTruth) -> dict[QueryKind, list[Query]]:
    """Every query the house allows, by kind, each naming one thing unambiguously."""
    names = Counter((o.category, o.colour) for o in truth.objects)
    pairs = Counter(c.rooms for c in truth.connections)
    boxes = Counter((c.category, c.room) for c in truth.containers)
    out: dict[QueryKind, list[Query]] = {k: [] for k, _ in QUERY_PLAN}
    for o in truth.objects:
        if names[(o.category, o.colour)] == 1:
            out["object_room"].append(Query(
                id="", kind="object_room", subject=o.id,
                text=f"Which room (id) is the {o.colour} {words(o.category)} in?",
                about={"category": o.category, "colour": o.colour}))
    for d in truth.doors:
        a, b = sorted(d.rooms)
        if pairs[(a, b)] == 1:
            out["door_state"].append(Query(
                id="", kind="door_state", subject=d.id,
                text=f"Is the door between {_room(truth, a)} and {_room(truth, b)} open, "
                "closed or locked?", about={"rooms": [a, b]}))
    for r in truth.rooms:
        out["room_neighbours"].append(Query(
            id="", kind="room_neighbours", subject=r.id,
            text=f"Which rooms (ids) share a doorway with {_room(truth, r.id)}?",
            about={"room": r.id}))
    for c in truth.containers:
        if boxes[(c.category, c.room)] == 1:
            out["container_state"].append(Query(
                id="", kind="container_state", subject=c.id,
                text=f"Is the {words(c.category)} in {_room(truth, c.room)} open, closed or "
                "unavailable?", about={"category": c.category, "room": c.room}))
    for a in AFFORDANCES:
        out["tools_for"].append(Query(id="", kind="tools_for", subject=a,
                                      text=f"Which tools (ids) can {a}?",
                                      about={"affordance": a}))
    for cat in sorted({o.category for o in truth.objects if o.kind == "object"}):
        out["object_count"].append(Query(
            id="", kind="object_count", subject=cat,
            text=f"How many {words(cat)}s are there in the house?", about={"category": cat}))
    return out


def plan_queries(truth: HouseTruth, rng: np.random.Generator) -> tuple[Query, ...]:
    """The queries of a scenario (drawn from the whole house)."""
    pools = _candidates(truth)
    out: list[Query] = []
    for kind, n in QUERY_PLAN:
        pool = pools[kind]
        for k in sorted(rng.permutation(len(pool))[:n].tolist()):
            out.append(pool[k].model_copy(update={"id": f"q{len(out)}"}))
    return tuple(out)


def to_send(queries: Sequence[Query], seen: Iterable[int]) -> list[dict[str, Any]]:
    """The queries as the agent sees them: id, kind, text, the description's fields, and
    the subject's instance id only when the agent detected it."""
    known = set(seen)
    out = []
    for q in queries:
        shown: dict[str, Any] = {"id": q.id, "kind": q.kind, "text": q.text, **q.about}
        field = ID_FIELD.get(q.kind)
        if field is not None and q.subject in known:
            shown[field] = q.subject
        out.append(shown)
    return out


def truth_of(q: Query, gt: HouseTruth) -> Any:
    """The right answer."""
    if q.kind == "object_room":
        obj = gt.object(int(q.subject))
        return None if obj is None else obj.room
    if q.kind == "door_state":
        return next((d.state for d in gt.doors if d.id == q.subject), None)
    if q.kind == "container_state":
        return next((c.state for c in gt.containers if c.id == q.subject), None)
    if q.kind == "room_neighbours":
        return gt.neighbours(int(q.subject))
    if q.kind == "tools_for":
        return gt.tools_for(str(q.subject))
    return sum(1 for o in gt.objects if o.category == q.subject)


def _int(value: Any) -> int | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value
    if isinstance(value, str) and value.strip().lstrip("-").isdigit():
        return int(value)
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return None


def f1(predicted: Iterable[Any], truth: Iterable[Any]) -> float:
    """F1 of two sets (1 when both are empty)."""
    p, t = set(predicted), set(truth)
    if not p and not t:
        return 1.0
    hits = len(p & t)
    return 0.0 if hits == 0 else 2 * hits / (len(p) + len(t))


def score_answer(kind: str, answer: Any, truth: Any) -> float:
    """One answer's score in [0, 1]; a missing or ``unknown`` answer scores 0."""
    if answer is None or truth is None:
        return 0.0
    if isinstance(answer, str) and answer.strip().lower() == "unknown":
        return 0.0
    if kind in ("room_neighbours", "tools_for"):
        if not isinstance(answer, list):
            return 0.0
        ids = [_int(a) for a in answer]
        return f1((i for i in ids if i is not None), truth)
    if kind == "object_room":
        return float(_int(answer) == truth)
    if kind == "object_count":
        n = _int(answer)
        return 0.0 if n is None else max(0.0, 1.0 - abs(n - truth) / max(1, truth))
    return float(isinstance(answer, str) and answer.strip().lower() == truth)


def grade(queries: Sequence[Query], answers: Mapping[str, Any], gt: HouseTruth | None
          ) -> tuple[GradedQuery, ...]:
    """Every query with its truth (at the end of exploration), the answer and its score."""
    out = []
    for q in queries:
        truth = None if gt is None else truth_of(q, gt)
        answer = answers.get(q.id)
        out.append(GradedQuery(id=q.id, kind=q.kind, text=q.text, truth=truth, answer=answer,
                               score=score_answer(q.kind, answer, truth)))
    return tuple(out)
