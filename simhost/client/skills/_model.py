"""The agent's world model: rooms, doors, connectivity, containers, objects, tools.

Everything comes from observations: a detection's world position is the robot's odometry
pose plus its relative position; its room is the room the robot is in (read from the sign
when it entered) when the line of sight crosses no doorway (walls block sight, so it must be
in the same room), else the room behind that doorway. A door belongs to the rooms it is seen
from directly, and to the two rooms the robot passes between when it crosses it; two such
rooms make a connection. A thing is as it was seen last: category, colour, position and
state of its latest sighting. A thing seen from afar may read as a look-alike
(``simhost.client.CONFUSABLE``, ``CONFUSABLE_COLOURS``): the detector reads an item right
within ``READS_RIGHT_WITHIN`` of the robot, furniture and containers within their own,
longer, distance, and beyond that the same look-alike each time; a thing's ``read_at`` is
the distance of the sighting its category and colour come from, and ``afar`` says when that
reading may be a look-alike.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Any

from simhost.client import CONFUSABLE, CONFUSABLE_COLOURS, OutputFiles

AFFORDANCES = {"sponge": "wipe", "cloth": "wipe", "knife": "cut", "scissors": "cut",
               "watering_can": "water", "jug": "water"}
SIZES = {"table": (1.2, 0.8), "counter": (1.6, 0.6), "shelf": (1.0, 0.4), "bed": (1.4, 1.9),
         "desk": (1.2, 0.6), "sofa": (1.8, 0.8), "cabinet": (0.8, 0.5), "drawer": (0.7, 0.5),
         "fridge": (0.7, 0.7), "bin": (0.45, 0.45)}
DOORWAY = 0.55
READS_RIGHT_WITHIN = {"object": 1.0, "tool": 1.0, "furniture": 5.0 / 3.0,
                      "container": 5.0 / 3.0}
"""Per kind, the distance (m) within which the Track 1 detector always reads a thing's
category and colour right: 1 m for items; furniture and containers scaled by their longer
sensing range (5 m against 3 m). Beyond it a thing may read as a look-alike (each thing
from a distance of its own, up to three times this); doors never do."""
READ_MARGIN = 0.1
"""How much nearer than ``READS_RIGHT_WITHIN`` a reading must be to count as close (the
distance the agent measures carries the detector's position noise)."""
_LOOKS_LIKE = ({c for alike in CONFUSABLE.values() for c in alike},
               {c for alike in CONFUSABLE_COLOURS.values() for c in alike})
"""The categories and colours a detector may report for something else."""


@dataclass
class Thing:
    """Something detected: a door, furniture, a container, an object or a tool."""

    id: int
    kind: str
    category: str
    colour: str
    state: str
    position: tuple[float, float]
    rooms: Counter[int] = field(default_factory=Counter)  # direct sightings per room
    via: dict[int, int] = field(default_factory=dict)  # door id -> robot room, seen through it
    last_seen: int = 0  # the step of its latest sighting (``Skills.steps`` at that reply)
    gone: bool = False
    latest: int | None = None  # room of the latest direct sighting
    seen_from: tuple[float, float] | None = None  # where the robot stood at the last sighting
    read_at: float = math.inf  # distance (m) of the sighting its category and colour are from

    @property
    def afar(self) -> bool:
        """Whether its category or colour may be a look-alike: read from beyond the
        distance where the detector reads this kind right (``READS_RIGHT_WITHIN``), as a
        name that something else may be read as. Go close (``Skills.go_to``) and match
        again to be sure."""
        sure = READS_RIGHT_WITHIN.get(self.kind)
        if sure is None or self.read_at <= sure - READ_MARGIN:
            return False
        return self.category in _LOOKS_LIKE[0] or self.colour in _LOOKS_LIKE[1]

    @property
    def room(self) -> int | None:
        if self.kind in ("object", "tool"):  # things that move: where it was seen last
            return self.latest
        return self.rooms.most_common(1)[0][0] if self.rooms else None


class WorldModel:
    """What the agent knows about the house."""

    def __init__(self) -> None:
        self.rooms: dict[int, str] = {}
        self.things: dict[int, Thing] = {}
        self.crossings: Counter[tuple[int, int, int]] = Counter()
        self.last_room: int | None = None
        self.step = 0
        self.moved: list[Thing] = []  # objects seen away from where they were last seen

    # ------------------------------------------------------------------ updates
    def observe(self, pose: tuple[float, float, float], room: int, room_type: str,
                detections: list[dict[str, Any]], step: int) -> list[Thing]:
        """Adds one observation; returns the things seen now."""
        self.step = step
        x, y, yaw = pose
        self.rooms[room] = room_type
        c, s = math.cos(yaw), math.sin(yaw)
        seen = []
        self.moved = []
        doors = [d for d in detections if d["kind"] == "door"]
        for d in doors + [d for d in detections if d["kind"] != "door"]:
            rx, ry = d["rel_pos"]
            pos = (x + c * rx - s * ry, y + s * rx + c * ry)
            t = self.things.get(d["id"])
            if t is None:
                t = self.things[d["id"]] = Thing(d["id"], d["kind"], d["category"], d["colour"],
                                                  d["state"], pos)
            if t.kind in ("object", "tool") and math.dist(t.position, pos) > 1.0:
                self.moved.append(t)
            t.state = self.seen_state(t, d["state"])
            t.position, t.last_seen, t.gone = pos, step, False
            t.category, t.colour = d["category"], d["colour"]
            t.read_at = math.hypot(rx, ry)
            t.seen_from = (x, y)
            through = self.doorway_between((x, y), pos, exclude=d["id"])
            if through is None:
                t.rooms[room] += 1
                t.latest = room
            else:
                t.via = {through: room}
                if t.kind in ("object", "tool"):
                    t.latest = None
            seen.append(t)
        if self.last_room is not None and room != self.last_room:
            door = self.nearest_door((x, y), 2.0)
            if door is not None:
                a, b = sorted((room, self.last_room))
                self.crossings[(a, b, door.id)] += 1
                door.rooms[room] += 3
                door.rooms[self.last_room] += 3
        self.last_room = room
        return seen

    @staticmethod
    def seen_state(t: Thing, reading: str) -> str:
        """A thing's state after a sighting. A locked door looks closed and an unavailable
        container looks as before (only a failed ``open`` or ``place`` tells): what a failure
        taught is kept until a sighting contradicts it (a door seen open is not locked)."""
        if t.state == "locked" and reading == "closed":
            return "locked"
        if t.state == "unavailable":
            return "unavailable"
        return reading

    def doorway_between(self, a: tuple[float, float], b: tuple[float, float],
                         exclude: int) -> int | None:
        """The door whose doorway the segment a→b passes through, if any."""
        ax, ay = a
        dx, dy = b[0] - ax, b[1] - ay
        length2 = dx * dx + dy * dy
        if length2 < 1e-6:
            return None
        for t in self.things.values():
            if t.kind != "door" or t.id == exclude:
                continue
            px, py = t.position
            u = ((px - ax) * dx + (py - ay) * dy) / length2
            if 0.02 < u < 0.98 and math.hypot(ax + u * dx - px, ay + u * dy - py) < DOORWAY:
                return t.id
        return None

    # ------------------------------------------------------------------ queries
    def room_of(self, t: Thing) -> int | None:
        if t.room is not None:
            return t.room
        for door_id, robot_room in t.via.items():
            rooms = self.door_rooms(door_id)
            if len(rooms) == 2 and robot_room in rooms:
                return rooms[0] if rooms[1] == robot_room else rooms[1]
        return None

    def door_rooms(self, door_id: int) -> list[int]:
        door = self.things.get(door_id)
        if door is None:
            return []
        return sorted(r for r, _ in door.rooms.most_common(2))

    def connections(self) -> list[tuple[int, int, int]]:
        out = []
        for t in self.things.values():
            if t.kind == "door":
                rooms = self.door_rooms(t.id)
                if len(rooms) == 2:
                    out.append((rooms[0], rooms[1], t.id))
        return out

    def neighbours(self, room: int) -> list[int]:
        return sorted({b if a == room else a for a, b, _ in self.connections() if room in (a, b)})

    def nearest_door(self, p: tuple[float, float], within: float) -> Thing | None:
        doors = [t for t in self.things.values() if t.kind == "door"]
        best = min(doors, key=lambda t: math.dist(t.position, p), default=None)
        return best if best is not None and math.dist(best.position, p) <= within else None

    def find(self, category: str, colour: str | None = None) -> list[Thing]:
        return [t for t in self.things.values() if t.category == category and not t.gone
                and (colour is None or t.colour == colour)]

    def of_kind(self, *kinds: str) -> list[Thing]:
        return [t for t in self.things.values() if t.kind in kinds]

    def room_by_type(self, room_type: str) -> list[int]:
        return [r for r, t in self.rooms.items() if t == room_type]

    # ------------------------------------------------------------------ files
    def document(self) -> dict[str, Any]:
        """``world_model.json``."""
        objects = []
        for t in self.of_kind("object", "tool"):
            objects.append({"id": t.id, "category": t.category, "colour": t.colour,
                            "room": self.room_of(t), "state": "removed" if t.gone else t.state,
                            "position": None if t.gone else [round(v, 3) for v in t.position]})
        return {
            "version": "eagc-world-model/v1",
            "step": self.step,
            "rooms": [{"id": r, "type": t} for r, t in sorted(self.rooms.items())],
            "connections": [{"rooms": [a, b], "door": d} for a, b, d in self.connections()],
            "doors": [{"id": t.id, "state": t.state if t.state in ("open", "closed", "locked")
                       else "unknown"} for t in self.of_kind("door")],
            "containers": [{"id": t.id, "type": t.category, "room": self.room_of(t),
                            "state": t.state if t.state in ("open", "closed", "unavailable")
                            else "unknown"} for t in self.of_kind("container")],
            "objects": objects,
            "affordances": [{"tool": t.id, "affordance": AFFORDANCES[t.category]}
                            for t in self.of_kind("tool")
                            if not t.gone and t.category in AFFORDANCES],
        }

    def write(self, files: OutputFiles) -> None:
        files.write(self.document(), "world_model.json")

    # ------------------------------------------------------------------ descriptions
    def on_what(self, t: Thing) -> Thing | None:
        """The furniture or container an item was seen on or in (the nearest, within 0.8 m)."""
        return min((f for f in self.of_kind("furniture", "container")
                    if math.dist(f.position, t.position) < 0.8),
                   key=lambda f: math.dist(f.position, t.position), default=None)

    def matches(self, ref: dict[str, Any]) -> list[Thing]:
        """Things that fit a description (category, colour, room type, what it is on), as
        they read at their latest sighting. A match whose ``afar`` is true was read from
        afar and may be a look-alike of what the description names (a red mug seen from
        3 m may be an orange bowl): go close and match again before acting on it."""
        out = []
        for t in self.find(ref["category"], ref.get("colour")):
            room = self.room_of(t)
            if ref.get("room") and (room is None or self.rooms.get(room) != ref["room"]):
                continue
            if ref.get("on"):
                base = self.on_what(t)
                if base is None or base.category != ref["on"]:
                    continue
            out.append(t)
        return out

    def answer(self, query: dict[str, Any]) -> Any:
        """The answer to one of the host's queries, from the model (None: no idea)."""
        kind = query["kind"]
        if kind == "tools_for":
            return sorted(t.id for t in self.of_kind("tool")
                          if not t.gone and AFFORDANCES.get(t.category) == query["affordance"])
        if kind == "room_neighbours":
            return self.neighbours(query["room"]) if query["room"] in self.rooms else None
        if kind == "object_count":
            return len(self.find(query["category"])) or None
        if kind == "object_room":
            found = self.things.get(query.get("object", -1)) or next(
                iter(self.find(query["category"], query["colour"])), None)
            return None if found is None else self.room_of(found)
        if kind == "door_state":
            want = sorted(query["rooms"])
            door = self.things.get(query.get("door", -1)) or next(
                (self.things[d] for a, b, d in self.connections() if [a, b] == want), None)
            return None if door is None else door.state
        box = self.things.get(query.get("container", -1)) or next(
            (t for t in self.find(query["category"]) if self.room_of(t) == query["room"]), None)
        return None if box is None else box.state
