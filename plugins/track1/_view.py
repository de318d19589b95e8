"""What the episode viewer shows of a Track 1 episode (``Track1.episode_map``, ``.truth``).

- The map: the house from above as generated, the path drawn over it by the page. A team's
  view gets its plan (rooms, walls, doors and furniture) without the objects and tools,
  which the world model inventories; the organizer's view draws them.
- The truth (organizers only): the ``world_model.json`` graded at the end of exploration
  against the house as generated (``simhost.worlds.track1.initial_ground_truth``: rooms,
  room-graph edges, doors, containers and objects; the truth the scorer uses is taken when
  exploration ends, so a door the agent opened or an object moved during exploration can
  differ here). Lines name what the model missed (``missing``), invented (``extra``) or got
  wrong (``wrong``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from plugins._views import EpisodeMap, RecordedEpisode, TruthReport
from plugins.track1._episode import EXPLORATION
from plugins.track1._types import Track1Scenario
from schemas import WorldModel, parse_json

#: Lines listed per kind of difference, at most.
MAX_LINES = 40
#: How to read the truth's lines.
TRUTH_NOTE = ("Against the house as generated; the score uses the truth as exploration "
              "ended (a door opened during exploration may differ). The score card's "
              "metrics are what the score counted.")


def house_map(episode: RecordedEpisode) -> EpisodeMap:
    """The house from above (its plan only, in a team's view)."""
    from simhost.worlds.track1 import (
        TOPDOWN_MARGIN,
        TOPDOWN_SCALE,
        generate_house,
        render_topdown,
    )

    spec = Track1Scenario.of(episode.scenario)
    layout = generate_house(episode.scenario.seed, params=spec.split.params)
    img = render_topdown(layout) if episode.organizer else render_topdown(_Plan(layout))
    height = float(layout.extent[1])
    caption = "the house from above" + (
        "" if episode.organizer else " (its plan: the items are not drawn)")
    return EpisodeMap(rgb=np.asarray(img, np.uint8)[:, :, :3], ox=TOPDOWN_MARGIN,
                      oy=TOPDOWN_MARGIN + height * TOPDOWN_SCALE, scale=TOPDOWN_SCALE,
                      caption=caption)


class _Plan:
    """A house for ``render_topdown`` as generated, without its objects and tools."""

    def __init__(self, layout: Any) -> None:
        self.layout = layout

    def ground_truth(self) -> Any:
        from simhost.worlds.track1 import initial_ground_truth

        return initial_ground_truth(self.layout).model_copy(update={"objects": ()})


def model_against_truth(episode: RecordedEpisode) -> TruthReport | None:
    """The exploration snapshot's ``world_model.json`` against the house (None: there is
    none); ``schemas.SchemaError`` when it does not parse."""
    graded = episode.folder / "host" / "snapshots" / EXPLORATION / "world_model.json"
    if not graded.is_file():
        return None
    model = parse_json(graded.read_bytes(), WorldModel, source="world_model.json")
    return TruthReport(of=f"{EXPLORATION} · world_model.json",
                       lines=tuple(differences(episode, model)), note=TRUTH_NOTE)


def _listed(label: str, items: list[str]) -> list[str]:
    if not items:
        return []
    more = f" … and {len(items) - MAX_LINES} more" if len(items) > MAX_LINES else ""
    return [f"{label} ({len(items)}): {', '.join(items[:MAX_LINES])}{more}"]


def differences(episode: RecordedEpisode, model: WorldModel) -> list[str]:
    """What ``model`` (a world_model.json) gets wrong about the scenario's house."""
    from simhost.worlds.track1 import generate_house, initial_ground_truth

    spec = Track1Scenario.of(episode.scenario)
    gt = initial_ground_truth(generate_house(episode.scenario.seed, params=spec.split.params))
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
