#!/usr/bin/env python
"""Learns the memory-free policy's doorway choice offline, from generated houses.

    python examples/track1_memoryfree/train_doorways.py [--houses 2000] [--out doorways.npz]

Plays nothing: it resets the public Gymnasium envs (``eagc/House-v0`` and
``eagc/HouseChallenge-v0``, the official splits' houses) on training seeds (from 2 * 10**7
on, away from any evaluation seed and from the look-ahead priors' seeds) and reads each
house's ground truth through the env's organizer API, which is public offline. From the
counts it fits, with add-one smoothing:

- ``neighbour``: P(type of the room behind a doorway | type of this room);
- ``furniture``: P(a piece of this furniture category stands in a room | its type), the
  likelihood of what is seen through a doorway;
- ``degree``: the mean number of doorways of a room of each type (a hallway leads on);
- for the queries it answers without a map (``answers.py``): ``door_open``, P(a door is
  open | the types of its two rooms); ``container_closed``, P(a container of each category
  is closed); ``count_answer``, per item category, the count that scores best on average
  (1 - relative error).

The policy combines them (naive Bayes) into what a doorway in view leads to, given the room
it is in and the furniture it sees beyond the doorway. Needs the eagc simulator
(``pip install eagc[sim]``); about a minute on one core per 1000 houses; a few kB.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOM_TYPES = ("kitchen", "living_room", "bedroom", "bathroom", "hallway", "storage")
FURNITURE = ("table", "counter", "shelf", "bed", "desk", "sofa", "cabinet", "drawer", "fridge",
             "bin")
CONTAINERS = ("cabinet", "drawer", "fridge", "bin")
ITEMS = ("mug", "apple", "book", "plate", "towel", "bottle", "bowl", "bread", "plant")
FIRST_SEED = 2 * 10**7


def best_count(counts: list[int]) -> int:
    """The answer to "how many?" with the best mean score (1 - relative error, floor 0)."""
    if not counts:
        return 1
    t = np.asarray(counts, float)
    scores = [float(np.maximum(0.0, 1.0 - np.abs(n - t) / t).mean()) for n in range(1, 13)]
    return 1 + int(np.argmax(scores))


def learn(houses: int) -> dict[str, np.ndarray]:
    import gymnasium as gym

    import simhost.worlds.track1  # noqa: F401 - registers the Track 1 envs

    r, f = len(ROOM_TYPES), len(FURNITURE)
    neighbour = np.ones((r, r))
    present = np.ones((r, f))
    rooms_of = np.full(r, 2.0)  # add-one smoothing of a Bernoulli: one room with, one without
    degree = np.zeros((r, 2))
    door_open = np.ones((r, r, 2))  # add-one smoothing: (open, all) counts start at (1, 2)
    door_open[..., 1] = 2.0
    closed = np.tile([1.0, 2.0], (len(CONTAINERS), 1))
    counts: dict[str, list[int]] = {c: [] for c in ITEMS}
    for split, env_id in enumerate(("eagc/House-v0", "eagc/HouseChallenge-v0")):
        env = gym.make(env_id, render_rgbd=False)
        for k in range(houses // 2):
            env.reset(seed=FIRST_SEED + 2 * k + split)
            truth = env.unwrapped.ground_truth()
            kind = [ROOM_TYPES.index(x.type) for x in truth.rooms]
            for c in truth.connections:
                a, b = (kind[x] for x in c.rooms)
                neighbour[a, b] += 1
                neighbour[b, a] += 1
            for d in truth.doors:
                a, b = (kind[x] for x in d.rooms)
                for i, j in {(a, b), (b, a)}:
                    door_open[i, j] += (d.state == "open", 1)
            for box in truth.containers:
                closed[CONTAINERS.index(box.category)] += (box.state == "closed", 1)
            for item in ITEMS:
                n = sum(1 for o in truth.objects if o.category == item)
                if n:
                    counts[item].append(n)
            for room, t in enumerate(kind):
                rooms_of[t] += 1
                degree[t] += (len(truth.neighbours(room)), 1)
                here = {p.category for p in (*truth.furniture, *truth.containers)
                        if p.room == room}
                for cat in here:
                    present[t, FURNITURE.index(cat)] += 1
        env.close()
    return {
        "room_types": np.array(ROOM_TYPES), "furniture_types": np.array(FURNITURE),
        "neighbour": neighbour / neighbour.sum(axis=1, keepdims=True),
        "furniture": present / rooms_of[:, None],
        "degree": degree[:, 0] / np.maximum(degree[:, 1], 1),
        "door_open": door_open[..., 0] / door_open[..., 1],
        "container_types": np.array(CONTAINERS),
        "container_closed": closed[:, 0] / closed[:, 1],
        "item_types": np.array(ITEMS),
        "count_answer": np.array([best_count(counts[c]) for c in ITEMS]),
        "houses": np.array(houses),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--houses", type=int, default=2000, help="houses to learn from")
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("doorways.npz"))
    args = ap.parse_args()
    t0 = time.perf_counter()
    tables = learn(args.houses)
    np.savez_compressed(args.out, **tables)
    print(f"learned from {args.houses} houses in {time.perf_counter() - t0:.0f} s: "
          f"{args.out} ({args.out.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
