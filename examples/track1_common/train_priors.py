#!/usr/bin/env python
"""Learns the look-ahead priors of the Track 1 baselines offline, from generated houses.

    python examples/track1_common/train_priors.py [--houses 3000] [--out priors.npz]

Plays nothing: it resets the public Gymnasium envs (``eagc/House-v0`` and
``eagc/HouseChallenge-v0``, the official splits' houses) on training seeds (from 10**7 on,
away from any evaluation seed) and reads each house's ground truth through the env's
organizer API, which is public offline. From the counts it fits, with add-one smoothing:

- ``room_type``: P(room type) of a room behind an unexplored doorway, and ``adjacent``:
  P(neighbour's type | this room's type);
- ``rooms``: P(number of rooms) per split;
- ``items_in_room``: the mean number of objects and tools per room type;
- ``category_room``: P(room type | an item of this category), and ``category_furniture``:
  P(furniture category it rests on or in | category);
- ``hidden``: P(an item is in a closed container | furniture category), and
  ``items_on``: the mean number of items on or in a piece of each furniture category;
- ``furniture_room``: P(room type | a piece of furniture of this category is in view).

Needs the eagc simulator (``pip install eagc[sim]``); takes about a minute on one core per
1000 houses. The result is a few kB: ``priors.npz`` beside this script.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOM_TYPES = ("kitchen", "living_room", "bedroom", "bathroom", "hallway", "storage")
FURNITURE = ("table", "counter", "shelf", "bed", "desk", "sofa", "cabinet", "drawer", "fridge",
             "bin")
ITEMS = ("mug", "apple", "book", "plate", "towel", "bottle", "bowl", "bread", "plant",
         "sponge", "cloth", "knife", "scissors", "watering_can", "jug")
FIRST_SEED = 10**7


def learn(houses: int) -> dict[str, np.ndarray]:
    import gymnasium as gym

    import simhost.worlds.track1  # noqa: F401 - registers the Track 1 envs

    r, f, i = len(ROOM_TYPES), len(FURNITURE), len(ITEMS)
    room_type = np.ones(r)
    adjacent = np.ones((r, r))
    rooms = np.ones((2, 9))
    items_in_room = np.zeros((r, 2))
    category_room = np.ones((i, r))
    category_furniture = np.ones((i, f))
    hidden = np.ones((f, 2))
    items_on = np.zeros((f, 2))
    furniture_room = np.ones((f, r))
    for split, env_id in enumerate(("eagc/House-v0", "eagc/HouseChallenge-v0")):
        env = gym.make(env_id, render_rgbd=False)
        for k in range(houses // 2):
            env.reset(seed=FIRST_SEED + 2 * k + split)
            truth = env.unwrapped.ground_truth()
            kind = [ROOM_TYPES.index(x.type) for x in truth.rooms]
            rooms[split, len(truth.rooms)] += 1
            for t in kind:
                room_type[t] += 1
            for c in truth.connections:
                a, b = (kind[x] for x in c.rooms)
                adjacent[a, b] += 1
                adjacent[b, a] += 1
            places = {p.id: p for p in (*truth.furniture, *truth.containers)}
            for p in places.values():
                furniture_room[FURNITURE.index(p.category), kind[p.room]] += 1
                items_on[FURNITURE.index(p.category)] += (
                    sum(o.receptacle == p.id for o in truth.objects), 1)
            per_room = np.zeros(len(kind))
            for o in truth.objects:
                per_room[o.room] += 1
                place = places[o.receptacle]
                c, p = ITEMS.index(o.category), FURNITURE.index(place.category)
                category_room[c, kind[o.room]] += 1
                category_furniture[c, p] += 1
                hidden[p, int(place.kind == "container" and place.state == "closed")] += 1
            for room, n in zip(kind, per_room, strict=True):
                items_in_room[room] += (n, 1)
        env.close()
    return {
        "room_types": np.array(ROOM_TYPES), "furniture": np.array(FURNITURE),
        "items": np.array(ITEMS),
        "room_type": room_type / room_type.sum(),
        "adjacent": adjacent / adjacent.sum(axis=1, keepdims=True),
        "rooms": rooms / rooms.sum(axis=1, keepdims=True),
        "items_in_room": items_in_room[:, 0] / np.maximum(items_in_room[:, 1], 1),
        "category_room": category_room / category_room.sum(axis=1, keepdims=True),
        "category_furniture": category_furniture / category_furniture.sum(axis=1,
                                                                          keepdims=True),
        "hidden": hidden[:, 1] / hidden.sum(axis=1),
        "items_on": items_on[:, 0] / np.maximum(items_on[:, 1], 1),
        "furniture_room": furniture_room / furniture_room.sum(axis=1, keepdims=True),
        "houses": np.array(houses),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--houses", type=int, default=3000, help="houses to learn from")
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("priors.npz"))
    args = ap.parse_args()
    t0 = time.perf_counter()
    priors = learn(args.houses)
    np.savez_compressed(args.out, **priors)
    print(f"learned from {args.houses} houses in {time.perf_counter() - t0:.0f} s: "
          f"{args.out} ({args.out.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
