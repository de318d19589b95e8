"""The queries answered without a map (``train_doorways.py`` → ``doorways.npz``). numpy only.

The policy keeps no map, so it answers the planning queries from what it sees now and from
what it learned offline about generated houses: the room ids it can know are those the
queries themselves name ("room 2 (the kitchen)") and the one whose sign it read last; an
item is put in the known room of the type that most often holds its category; a door is
as its two rooms' types make likelier; a container is closed (about 85 % are); a count is
the one that scores best on average; a room's neighbours are the known rooms of the type
with the most doorways (the hallway), or, for that type itself, every other known room.
Anything in view now is answered as seen."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
from priors import Priors

HERE = Path(__file__).resolve().parent
NAMED_ROOM = re.compile(r"room (\d+) \(the ([a-z ]+)\)")


class Answers:
    """The learned query tables and the answers they give."""

    def __init__(self, priors: Priors, path: Path = HERE / "doorways.npz") -> None:
        with np.load(path, allow_pickle=False) as data:
            self.room_types = [str(x) for x in data["room_types"]]
            self.degree = np.asarray(data["degree"], float)
            self.door_open = np.asarray(data["door_open"], float)
            self.containers = [str(x) for x in data["container_types"]]
            self.closed = np.asarray(data["container_closed"], float)
            self.items = [str(x) for x in data["item_types"]]
            self.counts = [int(x) for x in data["count_answer"]]
        self.priors = priors

    @staticmethod
    def named_rooms(queries: list[dict[str, Any]]) -> dict[int, str]:
        """The rooms (id: type) the queries' texts name."""
        return {int(n): "storage" if t == "storage room" else t.replace(" ", "_")
                for q in queries for n, t in NAMED_ROOM.findall(str(q.get("text", "")))}

    def answer(self, q: dict[str, Any], rooms: dict[int, str],
               visible: dict[int, dict[str, Any]]) -> Any:
        """One query's answer, or None to leave it unanswered."""
        kind = q.get("kind")
        for field in ("door", "container"):
            if q.get(field) in visible:  # in view now: as seen
                return visible[q[field]]["state"]
        if kind == "object_room":
            return self.priors.room_of(str(q.get("category")), rooms)
        if kind == "door_state":
            a, b = (self._type(rooms.get(int(r))) for r in q.get("rooms", (-1, -1)))
            p = self.door_open[a, b] if a is not None and b is not None else 0.6
            return "open" if p >= 0.5 else "closed"
        if kind == "container_state":
            c = str(q.get("category"))
            p = self.closed[self.containers.index(c)] if c in self.containers else 0.85
            return "closed" if p >= 0.5 else "open"
        if kind == "object_count":
            c = str(q.get("category"))
            return self.counts[self.items.index(c)] if c in self.items else 1
        if kind == "room_neighbours":
            return self._neighbours(int(q.get("room", -1)), rooms)
        return None

    def _type(self, room_type: str | None) -> int | None:
        return self.room_types.index(room_type) if room_type in self.room_types else None

    def _neighbours(self, room: int, rooms: dict[int, str]) -> list[int] | None:
        others = {r: t for r, t in rooms.items() if r != room}
        typed = {r: self._type(t) for r, t in others.items()}
        typed = {r: t for r, t in typed.items() if t is not None}
        if not typed:
            return None
        hub = max(set(typed.values()), key=lambda t: self.degree[t])
        own = self._type(rooms.get(room))
        if own is not None and self.degree[own] >= self.degree[hub]:
            return sorted(others)
        return sorted(r for r, t in typed.items() if t == hub)
