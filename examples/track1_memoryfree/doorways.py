"""What a doorway in view leads to (``train_doorways.py`` → ``doorways.npz``). numpy only.

Naive Bayes over the room behind a doorway: the prior is the learned P(neighbour's type |
this room's type), and each furniture category seen through the doorway multiplies in the
learned P(such a piece stands in a room | its type)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


class Doorways:
    """The learned doorway tables and the one question the policy asks of them."""

    def __init__(self, path: Path = HERE / "doorways.npz") -> None:
        with np.load(path, allow_pickle=False) as data:
            self.neighbour = np.asarray(data["neighbour"], float)
            self.furniture = np.asarray(data["furniture"], float)
            self.degree = np.asarray(data["degree"], float)
            self.room_types = [str(x) for x in data["room_types"]]
            self.furniture_types = [str(x) for x in data["furniture_types"]]

    def type_index(self, room_type: str | None) -> int | None:
        return self.room_types.index(room_type) if room_type in self.room_types else None

    def behind(self, room_type: str | None, seen: list[str]) -> np.ndarray:
        """P(type of the room behind a doorway) from this room's type (None: unknown) and the
        furniture categories seen through it."""
        t = self.type_index(room_type)
        p = (self.neighbour[t].copy() if t is not None
             else np.full(len(self.room_types), 1.0 / len(self.room_types)))
        for category in seen:
            if category in self.furniture_types:
                p *= self.furniture[:, self.furniture_types.index(category)]
        return p / max(float(p.sum()), 1e-12)

    def value(self, room_type: str | None, seen: list[str], want: np.ndarray) -> float:
        """How much going through a doorway helps find what is wanted: the chance the room
        behind is of a wanted type (``want``: per room type, 1 for the likeliest), plus a
        smaller share for the rooms one doorway further."""
        p = self.behind(room_type, seen)
        further = self.neighbour @ want
        return float(p @ (want + 0.3 * further * np.minimum(self.degree, 3.0) / 3.0))

    def room_of(self, seen: list[str]) -> np.ndarray:
        """P(type of the room it stands in) from the furniture categories it sees in it
        (no sign read yet): the same likelihoods, from a flat prior."""
        p = np.ones(len(self.room_types))
        for category in set(seen):
            if category in self.furniture_types:
                p *= self.furniture[:, self.furniture_types.index(category)]
        return p / max(float(p.sum()), 1e-12)
