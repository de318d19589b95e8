"""Properties of the Track 1 house generator over many seeds (pure Python, no MuJoCo)."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest

from simhost.worlds.track1 import (
    AFFORDANCES,
    MAX_IDS,
    ROOM_TYPES,
    HouseLayout,
    HouseParams,
    ItemSpec,
    LayoutError,
    generate_house,
    initial_ground_truth,
    is_two_edge_connected,
    shortest_room_path,
)
from simhost.worlds.track1._graph import has_cycle, reachable

STANDARD = [generate_house(seed) for seed in range(200)]
CHALLENGE = [generate_house(seed, params=HouseParams.challenge()) for seed in range(100)]
OFFICIAL = [generate_house(seed, params=HouseParams.standard()) for seed in range(100)]
ALL = STANDARD + CHALLENGE + OFFICIAL


def _nodes(layout: HouseLayout) -> list[int]:
    return [r.id for r in layout.rooms]


def test_room_counts_follow_the_split() -> None:
    assert {len(h.rooms) for h in STANDARD} == {3, 4, 5}
    assert {len(h.rooms) for h in OFFICIAL} == {3, 4, 5}
    assert {len(h.rooms) for h in CHALLENGE} == {6, 7, 8}


def test_room_types_and_special_rooms() -> None:
    for h in ALL:
        types = Counter(r.type for r in h.rooms)
        assert set(types) <= set(ROOM_TYPES)
        assert types["storage"] == 1 and types["kitchen"] == 1 and types["living_room"] == 1
        assert h.rooms[h.backup_room].type == "storage"
        assert h.rooms[h.start_room].type in ("hallway", "living_room")
        assert h.room_at(h.start[0], h.start[1]) == h.start_room


def test_room_graph_connected_with_cycles_and_no_bridges() -> None:
    """The documented guarantee: the door graph is 2-edge-connected, so it has a cycle and
    locking any one door leaves every room reachable from the start."""
    for h in ALL:
        nodes, edges = _nodes(h), h.edges()
        assert is_two_edge_connected(nodes, edges), h.seed
        if len(nodes) >= 4:
            assert has_cycle(nodes, edges), h.seed
        for door in h.doors:
            assert reachable(nodes, edges, h.start_room, blocked=[door.id]) == set(nodes)
            for target in nodes:
                path = shortest_room_path(nodes, edges, h.start_room, target, blocked=[door.id])
                assert path and path[0] == h.start_room and path[-1] == target


def test_every_item_sits_in_a_reachable_room_on_a_valid_slot() -> None:
    for h in ALL:
        nodes = set(_nodes(h))
        taken: set[tuple[int, int]] = set()
        for item in h.items:
            rec = h.entity(item.receptacle)
            assert rec is not None and h.kind_of(rec.id) in ("furniture", "container")
            assert rec.room in nodes
            assert 0 <= item.slot < rec.slots
            assert (rec.id, item.slot) not in taken
            taken.add((rec.id, item.slot))
            x, y, z = h.item_position(item, rec.id, item.slot)
            assert h.room_at(x, y) == rec.room
            assert z > 0


def test_ids_unique_and_bounded() -> None:
    for h in ALL:
        ids = [e.id for e in (*h.doors, *h.furniture, *h.items)]
        assert len(ids) == len(set(ids))
        assert min(ids) >= 1 and max(ids) < MAX_IDS


def test_names_are_unambiguous_and_tools_have_substitutes() -> None:
    for h in STANDARD:
        pairs = [(i.category, i.colour) for i in h.items]
        assert len(pairs) == len(set(pairs)), "without look-alikes category+colour names one"
    for houses, lo, hi in ((OFFICIAL, 1, 2), (CHALLENGE, 2, 4)):
        extra = []
        for h in houses:
            room = {f.id: f.room for f in h.furniture}
            pairs = Counter((i.category, i.colour) for i in h.items)
            extra.append(sum(n - 1 for n in pairs.values()))
            named = Counter((i.category, i.colour, room[i.receptacle]) for i in h.items)
            assert max(named.values()) == 1, "look-alikes stand in different rooms"
            assert all(i.kind == "object" for i in h.items if pairs[(i.category, i.colour)] > 1)
        assert lo <= np.mean(extra) <= hi and max(extra) <= hi
    for h in ALL:
        for aff in AFFORDANCES:
            tools = [i for i in h.items if aff in i.affordances]
            assert len(tools) >= 2, (h.seed, aff)
        assert any(f.initial_state == "dirty" for f in h.furniture)
        assert any(i.initial_state == "whole" for i in h.items)
        assert any(i.initial_state == "dry" for i in h.items)


def test_furniture_inside_its_room_and_not_overlapping() -> None:
    for h in ALL:
        for f in h.furniture:
            x0, y0, x1, y1 = f.footprint
            rx0, ry0, rx1, ry1 = h.rooms[f.room].bounds
            assert rx0 < x0 < x1 < rx1 and ry0 < y0 < y1 < ry1
            assert h.room_at(*f.access[:2]) == f.room
        boxes = [f.footprint for f in h.furniture]
        for i, a in enumerate(boxes):
            for b in boxes[i + 1 :]:
                assert not (a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3])


def _free_space(h: HouseLayout, radius: float = 0.25, res: float = 0.1) -> np.ndarray:
    """Independent of the generator: obstacles are wall boxes and furniture, inflated."""
    width, height = h.extent
    xs = (np.arange(int(width / res)) + 0.5) * res
    ys = (np.arange(int(height / res)) + 0.5) * res
    px, py = np.meshgrid(xs, ys)
    free = np.ones(px.shape, dtype=bool)
    rects = [
        (
            w.centre[0] - w.half[0],
            w.centre[1] - w.half[1],
            w.centre[0] + w.half[0],
            w.centre[1] + w.half[1],
        )
        for w in h.walls
    ]
    rects += [f.footprint for f in h.furniture]
    for d in h.doors:  # the open panel, standing out of the wall into the swing room
        (hx, hy), (nx, ny) = d.hinge, d.swing_normal
        ex, ey = hx + nx * d.width, hy + ny * d.width
        rects.append((min(hx, ex), min(hy, ey), max(hx, ex), max(hy, ey)))
    for x0, y0, x1, y1 in rects:
        dx = np.maximum(np.maximum(x0 - px, 0), px - x1)
        dy = np.maximum(np.maximum(y0 - py, 0), py - y1)
        free &= dx * dx + dy * dy >= radius * radius
    return free


def _flood(free: np.ndarray, seed: tuple[int, int]) -> np.ndarray:
    reach = np.zeros_like(free)
    reach[seed] = True
    while True:
        grown = reach.copy()
        grown[1:] |= reach[:-1]
        grown[:-1] |= reach[1:]
        grown[:, 1:] |= reach[:, :-1]
        grown[:, :-1] |= reach[:, 1:]
        grown &= free
        if np.array_equal(grown, reach):
            return reach
        reach = grown


@pytest.mark.parametrize("houses", [STANDARD[:80], CHALLENGE[:30]], ids=["standard", "challenge"])
def test_every_access_pose_and_doorway_reachable_from_the_start(houses: list[HouseLayout]) -> None:
    """With every door open (panels standing in the way), a disc robot can drive from its
    start to every furniture access pose (hence to every object) and through every doorway."""
    for h in houses:
        free = _free_space(h)
        cell = (int(h.start[1] / 0.1), int(h.start[0] / 0.1))
        assert free[cell], h.seed
        reach = _flood(free, cell)
        points = [f.access[:2] for f in h.furniture] + [d.centre for d in h.doors]
        for x, y in points:
            assert reach[int(y / 0.1), int(x / 0.1)], (h.seed, x, y)


def test_same_seed_same_layout_and_seeds_differ() -> None:
    for seed in (0, 7, 123456789):
        a, b = generate_house(seed), generate_house(seed)
        assert a == b and a.digest() == b.digest()
    digests = {h.digest() for h in STANDARD}
    assert len(digests) == len(STANDARD)
    assert generate_house(5, params=HouseParams.challenge()) != generate_house(5)


def test_layout_json_round_trip() -> None:
    h = STANDARD[11]
    again = HouseLayout.model_validate_json(h.model_dump_json())
    assert again.digest() == h.digest()
    truth = initial_ground_truth(h)
    assert {r.id for r in truth.rooms} == set(_nodes(h))
    assert len(truth.connections) == len(h.doors)


@pytest.mark.parametrize("seed", [-1, 1.5, True, "3"])
def test_bad_seed_is_refused(seed: object) -> None:
    with pytest.raises(LayoutError, match="non-negative int"):
        generate_house(seed)  # type: ignore[arg-type]


def test_bad_params_are_refused_with_a_reason() -> None:
    with pytest.raises(ValueError, match="rooms"):
        HouseParams(rooms=(2, 5))
    with pytest.raises(ValueError, match="two tool categories"):
        lone = ItemSpec(
            category="knife",
            shape="box",
            size=(0.1, 0.02, 0.01),
            colours=("red",),
            receptacles=("table",),
            affordances=("cut",),
        )
        HouseParams(items=(lone,))
    with pytest.raises(ValueError, match="tools_per_affordance"):
        HouseParams(tools_per_affordance=1)


def test_params_pack_changes_the_mix() -> None:
    params = HouseParams(rooms=(4, 4), objects_per_room=(1, 1), cell_size=(4.0, 4.0))
    h = generate_house(3, params=params)
    assert len(h.rooms) == 4
    assert all(math.isclose(w, 4.0) for w in h.col_widths)
    assert h.params_digest == params.digest() != HouseParams().digest()
