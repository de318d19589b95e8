"""Priors learned offline on generated houses (``train_priors.py`` → ``priors.npz``): what
lies beyond an unexplored doorway and where things tend to be. numpy only."""

from __future__ import annotations

from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


class Priors:
    """The learned tables, with the lookups the planners use."""

    def __init__(self, path: Path = HERE / "priors.npz") -> None:
        with np.load(path, allow_pickle=False) as data:
            self.tables = {k: data[k] for k in data.files}
        self.room_types = [str(x) for x in self.tables["room_types"]]
        self.furniture = [str(x) for x in self.tables["furniture"]]
        self.items = [str(x) for x in self.tables["items"]]

    def _room(self, room_type: str | None) -> int | None:
        return self.room_types.index(room_type) if room_type in self.room_types else None

    def items_behind(self, room_type: str | None) -> float:
        """Expected items in the room behind an unexplored doorway of a room of this type."""
        per_type = self.tables["items_in_room"]
        t = self._room(room_type)
        dist = self.tables["room_type"] if t is None else self.tables["adjacent"][t]
        return float(dist @ per_type)

    def items_on(self, furniture: str) -> float:
        """Expected items on or in a piece of this furniture category."""
        if furniture not in self.furniture:
            return 0.0
        return float(self.tables["items_on"][self.furniture.index(furniture)])

    def hidden(self, furniture: str) -> float:
        """Chance that an item on or in it is shut away (a closed container)."""
        if furniture not in self.furniture:
            return 0.0
        return float(self.tables["hidden"][self.furniture.index(furniture)])

    def where(self, category: str, furniture: str, room_type: str | None) -> float:
        """How likely an item of ``category`` is on or in a piece of ``furniture`` in a room
        of ``room_type`` (unknown room: its type is averaged out)."""
        if category not in self.items or furniture not in self.furniture:
            return 0.0
        c = self.items.index(category)
        on = self.tables["category_furniture"][c, self.furniture.index(furniture)]
        t = self._room(room_type)
        room = (self.tables["category_room"][c, t] if t is not None
                else 1.0 / len(self.room_types))
        return float(on * room)

    def room_of(self, category: str, rooms: dict[int, str]) -> int | None:
        """The known room where an item of ``category`` most likely is."""
        if category not in self.items or not rooms:
            return None
        c = self.items.index(category)
        table = self.tables["category_room"][c]
        return max(rooms, key=lambda r: table[self.room_types.index(rooms[r])]
                   if rooms[r] in self.room_types else 0.0)

    def room_share(self, category: str, room_type: str | None) -> float:
        """How likely an item of ``category`` is in a room of ``room_type`` relative to the
        likeliest room type (1 for the likeliest; 1 when either is unknown)."""
        if category not in self.items or room_type not in self.room_types:
            return 1.0
        row = self.tables["category_room"][self.items.index(category)]
        return float(row[self.room_types.index(room_type)] / max(float(row.max()), 1e-9))
