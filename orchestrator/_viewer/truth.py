"""Organizers only: an agent's model beside the hidden truth, item by item.

Track 1: the ``world_model.json`` graded at the end of exploration against the house as
generated (``simhost.worlds.track1.initial_ground_truth``: rooms, room-graph edges, doors,
containers and objects; the truth the scorer uses is taken when exploration ends, so a
door the agent opened or an object moved during exploration can differ here). Lines name
what the model missed (``missing``), invented (``extra``) or got wrong (``wrong``).
"""

from __future__ import annotations

from typing import Any

from schemas import WorldModel
from simhost.host._records import ScenarioRecord

#: Lines listed per kind of difference, at most.
MAX_LINES = 40


def _listed(label: str, items: list[str]) -> list[str]:
    if not items:
        return []
    more = f" … and {len(items) - MAX_LINES} more" if len(items) > MAX_LINES else ""
    return [f"{label} ({len(items)}): {', '.join(items[:MAX_LINES])}{more}"]


def track1_differences(scenario: ScenarioRecord, model: WorldModel) -> list[str]:
    """What ``model`` (a world_model.json) gets wrong about the scenario's house."""
    from plugins.track1 import Track1
    from simhost.worlds.track1 import generate_house, initial_ground_truth

    spec = Track1().hidden(scenario)
    gt = initial_ground_truth(generate_house(scenario.seed, params=spec.split.params))
    out: list[str] = []

    rooms = {r.id: r.type for r in gt.rooms}
    given = {r.id: r.type for r in model.rooms}
    out += _listed("rooms missing", [f"{i} {t}" for i, t in rooms.items() if i not in given])
    out += _listed("rooms extra", [str(i) for i in given if i not in rooms])
    out += _listed("rooms of the wrong type", [f"{i} ({given[i]}, is {t})"
                                               for i, t in rooms.items()
                                               if i in given and given[i] != t])

    edges = {frozenset(c.rooms) for c in gt.connections}
    named = {frozenset(c.rooms) for c in model.connections}

    def edge(e: frozenset[Any]) -> str:
        return "-".join(str(x) for x in sorted(e, key=str))

    out += _listed("room-graph edges missing", [edge(e) for e in edges - named])
    out += _listed("room-graph edges extra", [edge(e) for e in named - edges])

    for label, truth, entries in (
            ("doors", {d.id: d.state for d in gt.doors}, model.doors),
            ("containers", {c.id: c.state for c in gt.containers}, model.containers)):
        states = {d.id: d.state for d in entries}
        out += _listed(f"{label} missing", [str(i) for i in truth if i not in states])
        out += _listed(f"{label} in the wrong state", [
            f"{i} ({states[i]}, is {s})" for i, s in truth.items()
            if i in states and states[i] != s])

    objects = {o.id: (o.category, o.room) for o in gt.objects}
    listed = {o.id: (o.category, o.room) for o in model.objects}
    out += _listed("objects missing", [f"{i} {c} in room {r}" for i, (c, r) in
                                       objects.items() if i not in listed])
    out += _listed("objects extra", [str(i) for i in listed if i not in objects])
    out += _listed("objects wrong", [
        f"{i} ({listed[i][0]} in room {listed[i][1]}, is {c} in room {r})"
        for i, (c, r) in objects.items() if i in listed and listed[i] != (c, r)])
    return out or ["no difference"]
