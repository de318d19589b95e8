"""Matching a world model written under the agent's own ids to the truth (the ``vision``
split, ``plugins.track1._matching``): a model under permuted ids scores as the original, and
a thing written far from where it is matches nothing."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from plugins.track1._matching import UNMATCHED, match, matched, rename, rename_answer
from plugins.track1._score import model_parts, unmatched_notes
from schemas import Affordance, Connection, ContainerState, DoorState, ObjectEntry, Room, WorldModel
from simhost.worlds.track1 import HouseEnv, HouseTruth

SEED = 21001


@pytest.fixture(scope="module")
def truth() -> Iterator[HouseTruth]:
    env = HouseEnv(split="vision")
    try:
        env.reset(seed=SEED)
        yield env.ground_truth()
    finally:
        env.close()


def _model(truth: HouseTruth, ids: dict[int, int] | None = None) -> WorldModel:
    """The true house as a world model, its instance ids through ``ids`` (rooms stay)."""
    own = (lambda i: i) if ids is None else ids.__getitem__
    return WorldModel(
        rooms=[Room(id=r.id, type=r.type) for r in truth.rooms],
        connections=[Connection(rooms=c.rooms, door=own(c.door)) for c in truth.connections],
        doors=[DoorState(id=own(d.id), state=d.state) for d in truth.doors],  # type: ignore[arg-type]
        containers=[ContainerState(id=own(c.id), type=c.category, room=c.room,  # type: ignore[arg-type]
                                   state=c.state) for c in truth.containers],
        objects=[ObjectEntry(id=own(o.id), category=o.category, colour=o.colour, room=o.room,
                             receptacle=own(o.receptacle), position=o.position[:2],
                             state=o.state) for o in truth.objects],
        affordances=[Affordance(tool=own(a.tool), affordance=a.affordance)
                     for a in truth.affordances])


def _permutation(truth: HouseTruth) -> dict[int, int]:
    ids = sorted({d.id for d in truth.doors} | {f.id for f in (*truth.furniture,
                                                                *truth.containers)}
                 | {o.id for o in truth.objects})
    order = np.random.default_rng(7).permutation(len(ids))
    return {i: 500 + int(k) for i, k in zip(ids, order, strict=True)}


def test_a_model_under_permuted_ids_scores_as_the_original(truth: HouseTruth) -> None:
    assert truth.containers and truth.affordances and truth.doors
    ids = _permutation(truth)
    original, own = _model(truth), _model(truth, ids)
    assert model_parts(own, truth, ())["states"] < 1.0  # unmatched, own ids score as unknown
    found = match(own, truth)
    for kind, entries in (("doors", truth.doors), ("containers", truth.containers),
                          ("objects", truth.objects)):
        table = getattr(found, kind)
        assert {ids[e.id]: e.id for e in entries} == table, kind
    renamed = rename(own, found)
    assert model_parts(renamed, truth, ()) == model_parts(original, truth, ())
    assert model_parts(renamed, truth, ()) == {"queries": 0.0, "topology": 1.0, "objects": 1.0,
                                               "states": 1.0, "affordances": 1.0}
    for a, b in ((renamed.doors, original.doors), (renamed.containers, original.containers),
                 (renamed.affordances, original.affordances)):
        assert a == b
    assert [o.id for o in renamed.objects] == [o.id for o in original.objects]
    assert [c.door for c in renamed.connections] == [c.door for c in original.connections]
    tools = [ids[a.tool] for a in truth.affordances]
    assert rename_answer(tools, found.objects) == [a.tool for a in truth.affordances]
    assert rename_answer([9999], found.objects) == [-1]  # an id that pairs with nothing


def test_a_thing_written_far_off_matches_nothing(truth: HouseTruth) -> None:
    ids = _permutation(truth)
    own = _model(truth, ids)
    tool = truth.affordances[0].tool
    far = [o.model_copy(update={"position": (o.position[0] + 2.0, o.position[1])})
           if o.id == ids[tool] else o for o in own.objects]
    box = truth.containers[0]
    elsewhere = next(r.id for r in truth.rooms if r.id != box.room)
    boxes = [c.model_copy(update={"room": elsewhere}) if c.id == ids[box.id] else c
             for c in own.containers]
    moved = own.model_copy(update={"objects": far, "containers": boxes})
    found = match(moved, truth)
    assert ids[tool] not in found.objects and ids[box.id] not in found.containers
    assert len(found.objects) == len(truth.objects) - 1
    renamed = matched(moved, truth)
    assert renamed is not None
    unmatched = [o.id for o in renamed.objects if isinstance(o.id, str)]
    assert unmatched == [f"{UNMATCHED}{ids[tool]}"]
    assert f"{UNMATCHED}{ids[box.id]}" in {c.id for c in renamed.containers}
    parts = model_parts(renamed, truth, ())
    assert parts["states"] < 1.0 and parts["affordances"] < 1.0
    assert matched(None, truth) is None
    # The score card says so in the split's own terms (no ids were shown to be matched).
    [note] = unmatched_notes(renamed)
    entries = len(own.doors) + len(own.containers) + len(own.objects)
    assert note.startswith(f"world model: 2 of {entries} entries match nothing in the house")
    assert str(ids[tool]) in note and str(ids[box.id]) in note
    assert unmatched_notes(rename(own, match(own, truth))) == []
