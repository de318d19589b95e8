"""Track 1 memory-free reactive baseline (paper Table IV): the current observation and the
instruction, no persistent map or object memory.

Every step it looks at what the detector reports now: when the thing the current goal needs
next (the item, then where it goes or what it acts on) is in sight, it turns to it, drives
to it avoiding obstacles in the range scan, and acts; otherwise it goes to look closely at
the piece of furniture in view that most likely holds it (priors learned offline on
generated houses, ``priors.npz``, the look-ahead planner's: the policy's weights, not a
memory), opening closed containers; with none in view it searches by following the walls on
its right hand (furniture stands against walls, so this passes close to every surface and
through every open doorway), opening closed doors ahead. A failed ``open`` or ``place`` that
says ``locked`` or ``unavailable`` is logged as an exception. During exploration it follows
the walls and reports every sighting, and every doorway it passes from one signed room into
the next, to ``world_model.json`` (a write-only report: it never reads it back). Between
steps it keeps only what a reactive policy needs to act at all: which goal of the
instruction it is on (``simhost.client.skills.parse``), the room whose sign it read last,
how long ago (after a while, or when the goal names another room, it leaves through a
doorway in sight), the id of what it is approaching while that stays in view, and a step
counter (after a while it accepts another tool with the same use). The last action's result
is part of what it sees: it steps back when it stands in a door's way or a turn hits
something. Uses only ``simhost.client`` (``RemoteEnv``, ``OutputFiles``), the instruction
reader of ``simhost.client.skills``, numpy and the standard library. ``priors.py``,
``priors.npz`` and the entry point (``entry.py``) are the Track 1 baselines' library,
``examples/track1_common`` (this image is built ``FROM`` its image).
"""

from __future__ import annotations

import math
import sys
from collections import deque
from pathlib import Path
from typing import Any

_LIBRARY = Path(__file__).resolve().parent.parent / "track1_common"
if _LIBRARY.is_dir():  # a checkout; in the image the library sits beside this file (/app)
    sys.path.insert(1, str(_LIBRARY))

import numpy as np  # noqa: E402
from answers import Answers  # noqa: E402
from doorways import Doorways  # noqa: E402
from entry import main  # noqa: E402
from priors import Priors  # noqa: E402

from simhost.client import OutputFiles, RemoteEnv, TimeStep  # noqa: E402
from simhost.client.skills import AFFORDANCES, parse  # noqa: E402

REACH = {"object": 1.0, "tool": 1.0, "door": 1.3}
SIZES = {"table": 0.5, "counter": 0.55, "shelf": 0.4, "bed": 0.9, "desk": 0.45, "sofa": 0.6,
         "cabinet": 0.4, "drawer": 0.4, "fridge": 0.45, "bin": 0.3}
LOOKALIKE = {"mug": ("bowl", "bottle"), "bowl": ("mug", "plate"), "plate": ("bowl",),
             "book": ("towel",), "towel": ("book",), "bottle": ("mug",), "apple": ("bread",),
             "bread": ("apple",), "plant": ("bottle",), "sponge": ("cloth",),
             "cloth": ("sponge",), "knife": ("scissors",), "scissors": ("knife",),
             "watering_can": ("jug",), "jug": ("watering_can",)}
LOOKALIKE_COLOURS = {"red": ("orange",), "orange": ("red", "yellow"),
                     "yellow": ("orange", "white"), "white": ("yellow",), "blue": ("purple",),
                     "purple": ("blue",), "green": ("yellow",), "black": ("blue",)}
"""What a detector may read a thing as from afar: copies of the track's public tables for
objects and tools (``simhost.worlds.track1.CONFUSABLE``, ``CONFUSABLE_COLOURS``; the image cannot
import the simulator), kept equal by a test."""
CLOSE_LOOK = 1.0
"""Within this distance (m) a reading is trusted: a look-alike from afar is looked at closer."""
LOOSE = 0.35
"""After this share of the execution budget spent on one goal without it, it takes the
description loosely (an exception may have changed things): another tool with the same
use, the thing in any room, and every room type is worth a look."""
ROOM_PATIENCE = 40
"""Steps it searches a room of the likeliest type before leaving it (in proportion to the
likelihood for another type, at least ``MIN_PATIENCE``; a third of that in a room it came
back to)."""
MIN_PATIENCE = 10
EXPLORE_PATIENCE = 15
"""Steps along the walls of a room while exploring before it leaves by a doorway in view."""
SCAN = 6
"""Turns in place (45 degrees each) to look for something before moving on (with a
120-degree view, six turns see all round)."""
ROAM = 4
"""Steps it drives into the open part of a room before looking around again."""
ROAMS = 2
"""Such drives per room."""
BACK = 25
"""Steps in a room before it goes back out by the doorway it came in by."""
WALL_STEPS = 12
"""Steps along the walls looking for a way out between two looks all round for one."""
RECENT = 3
SURE = 0.8
"""How sure it must be of a room's type recognised from its furniture."""
"""Room signs it remembers (the last rooms passed, within a stage)."""
LOOK_AROUND = 6
"""Steps of turning in place on entering a room (45 degrees a step, 120 degrees seen)."""
UNLIKELY = 0.25
"""A room type holding what is wanted less than this often, relative to the likeliest
type, is left at once."""
STEP = 0.5
"""The farthest one move goes (m)."""
RADIUS = 0.3
"""Half the width of the corridor a move needs (the robot's radius and a margin, m)."""
CLOSE = 2.2
WORTH = 0.05
"""A piece of furniture is worth a close look when at least this share of the items of the
category rest on or in its kind (discounted by its distance: / (1 + m / 3))."""
"""Closer than this, what rests on a piece of furniture would be in sight."""


class Agent:
    def __init__(self, seed: int = 1) -> None:
        self.rng = np.random.default_rng(seed)
        self.priors = Priors()
        self.doorways = Doorways()
        self.answers = Answers(self.priors)
        self.files = OutputFiles()
        self.step = 0
        self.exec_steps = 0
        self.budget = 0
        self.goals: list[dict[str, Any]] = []
        self.current = 0
        self.logged: set[str] = set()
        self.last: dict[str, Any] | None = None
        self.drop = False
        self.sought: tuple = ()
        self.stuck = 0
        self.stage = ""
        self.new_stage()
        self.report: dict[str, dict[Any, dict[str, Any]]] = {
            k: {} for k in ("rooms", "connections", "doors", "containers", "objects",
                            "affordances")}

    # ------------------------------------------------------------------ its bounded state
    def new_stage(self) -> None:
        """Forgets everything but the instruction and the goal it is on: nothing of one
        stage reaches the next (exploration's sightings go to the report only)."""
        self.room, self.room_type = -1, ""
        self.recent: deque[int] = deque(maxlen=RECENT)
        """The last rooms whose sign it read (ids), this one excluded."""
        self.locked: deque[int] = deque(maxlen=2)
        """Doors whose ``open`` failed with ``locked`` (the last two)."""
        self.unusable: deque[int] = deque(maxlen=2)
        """Containers whose ``open``/``place`` failed with ``unavailable`` (the last two)."""
        self.refused: deque[int] = deque(maxlen=3)
        """Furniture where ``place`` failed for good (full: the last three)."""
        self.ruled_out: deque[int] = deque(maxlen=4)
        """Look-alikes it went closer to and found not to be what it wants (the last four)."""
        self.near_door: int | None = None
        """The door it last came within 1.5 m of (the one it entered by, after a sign)."""
        self.new_room(-1, "", revisit=False)

    def new_room(self, room: int, room_type: str, *, revisit: bool) -> None:
        """Reads a room sign: what it keeps of the room it left is its id and its door.
        Passing through a door from one signed room into the next is reported as a
        connection of the two (to the report only, like every sighting)."""
        if self.room >= 0 and room != self.room:
            self.recent.append(self.room)
            if room >= 0 and self.near_door is not None:
                pair = (min(room, self.room), max(room, self.room))
                self.report["connections"][pair] = {"rooms": list(pair),
                                                    "door": self.near_door}
        self.entry = self.near_door if room != self.room else None
        self.room, self.room_type = room, room_type
        self.revisit = revisit
        self.in_room = 0
        self.scan = 0
        self.door_scan = 0
        """Steps spent looking for a way out with none in view (a look all round, then
        ``WALL_STEPS`` along the walls, and again)."""
        self.inspected: set[int] = set()
        """Furniture of this room it has looked at from close up (ids, reset per room)."""
        self.door: int | None = None
        self.passing = 0
        self.roam, self.roams = 0, 0
        self.place: int | None = None
        """The piece of furniture it is going to look at (while in view)."""
        self.clear = 2 if self.entry is not None else 0
        """Steps straight on after a sign read in a doorway, to be clear of it."""

    def record(self, event: str, stage: str, exception_type: str | None = None,
               **data: Any) -> None:
        self.files.log(step=self.step, stage=stage, event=event, exception_type=exception_type,
                       data=data)

    # ------------------------------------------------------------------ what it sees
    @staticmethod
    def seen(obs: dict) -> list[dict[str, Any]]:
        out = obs["detections"]
        for d in out:
            d["dist"] = math.hypot(*d["rel_pos"])
            d["bearing"] = math.atan2(d["rel_pos"][1], d["rel_pos"][0])
        return out

    @staticmethod
    def through(d: dict, dets: list[dict]) -> dict | None:
        """The open doorway in view that ``d`` is seen through (it is in another room), if
        any: a doorway nearer on the same bearing."""
        for door in dets:
            if door["kind"] != "door" or door["id"] == d["id"] or door["state"] != "open":
                continue
            width = math.atan2(0.6, max(door["dist"], 0.3)) + 0.1
            if d["dist"] > door["dist"] + 0.4 and abs(math.remainder(
                    d["bearing"] - door["bearing"], math.tau)) < width:
                return door
        return None

    def recognise(self, dets: list[dict]) -> str:
        """The type of the room it stands in, from the furniture in view in it (the learned
        doorway tables), when no sign was read in this stage yet: "" until it is sure."""
        seen = [d["category"] for d in dets if d["kind"] in ("furniture", "container")
                and self.through(d, dets) is None]
        p = self.doorways.room_of(seen)
        best = int(np.argmax(p))
        return self.doorways.room_types[best] if seen and p[best] >= SURE else ""

    def write_model(self, obs: dict) -> None:
        """Adds what it sees now to ``world_model.json``: the file is a report of sightings,
        written and never read back (the policy keeps no map: it acts on the current
        observation only). A sighting replaces the previous one of the same id."""
        x, y, yaw = (float(v) for v in obs["odometry"])
        room = self.room
        c, s = math.cos(yaw), math.sin(yaw)
        out = self.report
        if room >= 0:
            out["rooms"][room] = {"id": room, "type": self.room_type}
        for d in self.seen(obs):
            dx, dy = d["rel_pos"]
            if d["kind"] == "door":
                out["doors"][d["id"]] = {"id": d["id"], "state": d["state"]}
            elif d["kind"] == "container":
                out["containers"][d["id"]] = {"id": d["id"], "type": d["category"],
                                              "room": room if room >= 0 else None,
                                              "state": d["state"]}
            elif d["kind"] in ("object", "tool"):
                out["objects"][d["id"]] = {"id": d["id"], "category": d["category"],
                                           "colour": d["colour"],
                                           "room": room if room >= 0 else None,
                                           "position": [x + c * dx - s * dy, y + s * dx + c * dy]}
                if d["category"] in AFFORDANCES:
                    out["affordances"][d["id"]] = {"tool": d["id"],
                                                   "affordance": AFFORDANCES[d["category"]]}
        self.files.write({"version": "eagc-world-model/v1", "step": self.step,
                          **{k: list(v.values()) for k, v in out.items()}}, "world_model.json")

    # ------------------------------------------------------------------ motion
    def toward(self, obs: dict, bearing: float, dist: float) -> dict[str, Any]:
        """A move toward a bearing (robot frame), steering to the nearest heading whose
        corridor (the robot's width, one step long) the range scan shows free."""
        scan = np.asarray(obs["range_scan"], float)
        n = len(scan)
        rays = np.arange(n) * (2 * math.pi / n)
        px, py = scan * np.cos(rays), scan * np.sin(rays)
        heads = np.arange(72) * (2 * math.pi / 72)
        along = np.outer(np.cos(heads), px) + np.outer(np.sin(heads), py)
        side = np.outer(-np.sin(heads), px) + np.outer(np.cos(heads), py)
        length = min(STEP, max(0.1, dist - 0.5)) + RADIUS
        clear = ~np.any((along > 0.0) & (along < length) & (np.abs(side) < RADIUS), axis=1)
        diff = np.abs(np.remainder(heads - bearing + math.pi, 2 * math.pi) - math.pi)
        if clear.any():
            bearing = float(heads[np.argmin(np.where(clear, diff, 9.0))])
        else:
            bearing = float(rays[np.argmax(scan)])
        bearing = math.remainder(bearing, math.tau)
        if abs(bearing) > math.pi / 4:
            return {"primitive": "move", "move": [0.0, math.copysign(1.0, bearing)]}
        return {"primitive": "move", "move": [min(1.0, max(0.2, dist / STEP)),
                                              bearing / (math.pi / 4)]}

    def wander(self, obs: dict, dets: list[dict], room_wanted: str | None = None
               ) -> dict[str, Any]:
        """Searches: along the walls on the right hand (furniture stands against walls, so
        this passes close to every surface), and out through a doorway in sight once this
        room has been searched for a while or is not the room the goal names."""
        doors = [d for d in dets if d["kind"] == "door" and d["id"] not in self.locked]
        leave = self.in_room > EXPLORE_PATIENCE or (self.goals and self.current < len(
            self.goals) and self.leaving(obs))
        if leave and doors and not int(obs["collided"][0]):
            # the nearest doorway, not back the way it came while another is in view
            door = min(doors, key=lambda d: d["dist"] + (9.0 if d["id"] == self.entry else 0.0))
            if door["state"] == "closed":
                if door["dist"] < 1.45 and abs(door["bearing"]) < 0.6:
                    return {"primitive": "open", "target": door["id"]}
                return self.toward(obs, door["bearing"], door["dist"])
            # through the doorway: aim at it, then a little beyond
            return self.toward(obs, door["bearing"], door["dist"] + 1.0)
        return self.follow_wall(obs, dets)

    def follow_wall(self, obs: dict, dets: list[dict]) -> dict[str, Any]:
        """One step of right-hand wall following; opens a closed door just ahead."""
        scan = np.asarray(obs["range_scan"], float)
        n = len(scan)
        deg = 360.0 / n

        def ray(angle: float) -> float:
            return float(scan[int(round(angle / deg)) % n])

        if int(obs["collided"][0]):  # turn in place toward the freer side
            if self.last is not None and self.last.get("primitive") == "move" and \
                    float(self.last["move"][0]) <= 0.0:  # a turn (or backing up) hit: back off
                return {"primitive": "move", "move": [-0.6, 0.0]
                        if float(self.last["move"][0]) == 0.0 else [0.4, 1.0]}
            left = sum(ray(a) for a in range(30, 151, 30))
            right_side = sum(ray(-a) for a in range(30, 151, 30))
            return {"primitive": "move", "move": [0.0, 1.0 if left >= right_side else -1.0]}
        for d in dets:
            if (d["kind"] == "door" and d["state"] == "closed" and d["dist"] < 1.45
                    and abs(d["bearing"]) < 0.6 and d["id"] not in self.locked):
                return {"primitive": "open", "target": d["id"]}
        front = min(ray(a) for a in (-20, -10, 0, 10, 20))
        right = min(ray(a) for a in (-80, -90, -100))
        front_right = ray(-45)
        if front < 0.85:
            return {"primitive": "move", "move": [0.0, 1.0]}  # blocked: turn left
        if right > 1.6 and front_right > 1.4:
            return {"primitive": "move", "move": [min(1.0, (front - 0.6) / 0.5), -1.0]}
        steer = max(-0.5, min(0.5, (0.8 - right) * 0.8))  # keep the wall 0.8 m away
        return {"primitive": "move", "move": [min(1.0, (front - 0.6) / 0.5), steer]}

    # ------------------------------------------------------------------ the task
    def loose(self) -> bool:
        """Whether it has spent long enough on this goal to take its description loosely."""
        return self.exec_steps > LOOSE * self.budget

    def fits(self, d: dict, ref: dict, *, here: bool = True) -> bool:
        """Whether a detection fits a description (its room only when known now)."""
        if d["category"] != ref["category"]:
            return False
        if ref.get("colour") and d["colour"] != ref["colour"]:
            return False
        if d["kind"] in ("object", "tool") and self.loose():
            return True  # it may have been moved out of the room the instruction names
        return not (here and ref.get("room") and self.room_type
                    and self.room_type != ref["room"])

    def maybe(self, d: dict, ref: dict) -> bool:
        """Whether a thing seen from afar may be the one described, read as a look-alike
        (worth a closer look): a look-alike category or colour, beyond ``CLOSE_LOOK``."""
        if d["kind"] not in ("object", "tool") or d["dist"] <= CLOSE_LOOK or \
                d["id"] in self.ruled_out:
            return False
        cat = d["category"] == ref["category"] or d["category"] in LOOKALIKE.get(
            ref["category"], ())
        col = not ref.get("colour") or d["colour"] == ref["colour"] or d["colour"] in \
            LOOKALIKE_COLOURS.get(ref["colour"], ())
        if not (cat and col) or self.fits(d, ref):
            return False
        return not (ref.get("room") and self.room_type and self.room_type != ref["room"]
                    and not self.loose())

    def fetching(self, obs: dict) -> bool:
        """Whether it is still after the thing to fetch (its hand is empty)."""
        return int(obs["held"][0]) < 0

    def wanted(self, obs: dict, dets: list[dict]) -> tuple[dict | None, str, dict]:
        """What to act on now, if it is in sight: (detection, primitive, extra fields)."""
        goal = self.goals[self.current]
        held = int(obs["held"][0])
        ref = goal["item"] if goal["kind"] == "place" else goal["tool"]
        if held < 0:
            items = [d for d in dets if d["kind"] in ("object", "tool") and self.fits(d, ref)]
            if not items and goal["kind"] == "use" and self.loose():
                items = [d for d in dets if d["kind"] == "tool"
                         and AFFORDANCES.get(d["category"]) == goal["affordance"]]
            if items:
                return min(items, key=lambda d: d["dist"]), "pick", {}
            maybe = [d for d in dets if self.maybe(d, ref)]
            return (min(maybe, key=lambda d: d["dist"]) if maybe else None), "look", {}
        if goal["kind"] == "place":
            dest = goal["dest"]
            here = self.room_type == dest["room"]
            dests = [d for d in dets if here and d["kind"] in ("furniture", "container")
                     and d["id"] not in self.unusable and d["id"] not in self.refused
                     and (d["category"] == dest["category"] or (
                         d["kind"] == "container" and goal["container"] and self.unusable))]
            best = min(dests, key=lambda d: (d["category"] != dest["category"], d["dist"]),
                       default=None)
            if best is not None and best["state"] == "closed":
                return best, "open", {}
            return best, "place", {}
        targets = [d for d in dets if self.fits(d, goal["target"])]
        return (targets[0] if targets else None), "use", {"tool": held}

    def promising(self, obs: dict, dets: list[dict]) -> dict | None:
        """The piece of furniture in view most likely to hold what is wanted (the learned
        share of its category resting on that kind, nearer first), among those of this
        room not yet looked at from close up. Marks what it is close to and faces as looked
        at."""
        category, _, on = self.wanted_now(obs)
        room = self.room_wanted(obs)
        if self.loose() and self.fetching(obs):
            on = None
        for d in dets:
            if d["kind"] not in ("furniture", "container"):
                continue
            shut = d["kind"] == "container" and d["state"] == "closed" and \
                d["id"] not in self.unusable
            if not shut and d["dist"] < CLOSE and abs(d["bearing"]) < 0.7 and \
                    d["id"] not in self.inspected:
                self.inspected.add(d["id"])
                if d["id"] == self.place:  # looked at: from here, look around a little
                    self.place, self.scan = None, SCAN // 2
        if room is not None and self.room_type and self.room_type != room:
            return None
        kept = [d for d in dets if d["id"] == self.place and d["id"] not in self.inspected]
        if kept:  # keeps to the piece it chose while it stays in view
            return kept[0]
        best, best_p = None, WORTH
        for d in dets:
            if d["kind"] not in ("furniture", "container") or d["id"] in self.inspected:
                continue
            if abs(d["bearing"]) > 1.0 or d["dist"] > 4.5 or self.through(d, dets):
                continue
            p = self.rests_on(category, d["category"])
            if on is not None:  # the instruction says what it rests on
                p = 1.0 if d["category"] == on else 0.0
            if p / (1 + d["dist"] / 3) > best_p:
                best, best_p = d, p / (1 + d["dist"] / 3)
        return best

    def rests_on(self, category: str, furniture: str) -> float:
        """The learned share of the items of a category that rest on or in a piece of this
        furniture category (whether this room is worth searching is decided apart)."""
        if category not in self.priors.items or furniture not in self.priors.furniture:
            return 0.0
        table = self.priors.tables["category_furniture"]
        return float(table[self.priors.items.index(category),
                           self.priors.furniture.index(furniture)])

    def wanted_now(self, obs: dict) -> tuple[str, str | None, str | None]:
        """The category needed next, the room the instruction names for it and what the
        instruction says it rests on."""
        goal = self.goals[self.current]
        if self.fetching(obs):
            ref = goal["item"] if goal["kind"] == "place" else goal["tool"]
        else:
            ref = goal["dest"] if goal["kind"] == "place" else goal["target"]
        return ref["category"], ref.get("room"), ref.get("on")

    def want_types(self, obs: dict) -> np.ndarray:
        """Per room type, how much what is needed next is looked for there, relative to the
        likeliest type: 1 for the room the instruction names; else the learned priors of
        the category by room type, times the chance that a room of the type has the piece
        of furniture the instruction says it rests on."""
        category, _, on = self.wanted_now(obs)
        room = self.room_wanted(obs)
        types = self.doorways.room_types
        if room is not None:
            return np.array([float(t == room) for t in types])
        if self.loose() and self.fetching(obs):
            on = None
        w = np.ones(len(types))
        if category in self.priors.items:
            w = np.array([self.priors.room_share(category, t) for t in types])
        elif category in self.doorways.furniture_types:
            w = self.doorways.furniture[:, self.doorways.furniture_types.index(category)]
        if on in self.doorways.furniture_types:
            w = w * self.doorways.furniture[:, self.doorways.furniture_types.index(on)]
        return w / max(float(w.max()), 1e-9)

    def act(self, obs: dict, dets: list[dict], stage: str) -> dict[str, Any]:
        if self.drop and int(obs["held"][0]) >= 0:  # the tool just used is not needed now
            spots = [d for d in dets if d["kind"] == "furniture" and d["id"] not in self.refused]
            thing, primitive, extra = min(spots, key=lambda d: d["dist"], default=None), \
                "place", {}
        else:
            self.drop = False
            thing, primitive, extra = self.wanted(obs, dets)
        # what it was approaching stays its target while in view (a look-alike reading of
        # it now and then does not turn it away); out of view, it is forgotten
        key = (self.current, int(obs["held"][0]))
        if thing is not None:
            self.lock = (key, thing["id"], primitive, extra)
        elif self.lock is not None and self.lock[0] == key:
            again = [d for d in dets if d["id"] == self.lock[1] and d["id"] not in
                     (*self.refused, *self.unusable, *self.locked)]
            if again:
                thing, primitive, extra = again[0], self.lock[2], self.lock[3]
            else:
                self.lock = None
        if thing is None or int(obs["collided"][0]):
            return self.search(obs, dets)
        if self.stuck >= 3:  # the way to it is blocked: search on
            self.stuck = 0
            return self.follow_wall(obs, dets)
        if primitive == "look":  # a look-alike from afar: closer, then it is known
            if thing["dist"] <= CLOSE_LOOK:
                self.ruled_out.append(thing["id"])
                self.lock = None
                return self.search(obs, dets)
            if abs(thing["bearing"]) > 0.6:
                return {"primitive": "move", "move": [0.0, max(-1.0, min(
                    1.0, thing["bearing"] / (math.pi / 4)))]}
            return self.toward(obs, thing["bearing"], thing["dist"])
        reach = REACH.get(thing["kind"], SIZES.get(thing["category"], 0.5) + 0.55)
        if abs(thing["bearing"]) > 0.6:
            return {"primitive": "move", "move": [0.0, max(-1.0, min(1.0, thing["bearing"]
                                                                    / (math.pi / 4)))]}
        if thing["dist"] <= reach:
            return {"primitive": primitive, "target": thing["id"], **extra}
        return self.toward(obs, thing["bearing"], thing["dist"])

    def search(self, obs: dict, dets: list[dict]) -> dict[str, Any]:
        """Nothing it needs is in view. In a room worth searching it looks at the likeliest
        furniture not yet seen from close up, turning in place to find some; once none is
        left (or after a while) it leaves by the doorway most likely to lead on. What it
        has looked at in this room counts for one thing sought: a new one starts afresh."""
        sought = (self.current, self.fetching(obs), self.loose())
        if sought != self.sought:
            self.sought = sought
            self.inspected.clear()
            self.in_room = min(self.in_room, ROOM_PATIENCE // 2)
            self.roams = 0
        if int(obs["collided"][0]):
            return self.follow_wall(obs, dets)
        if self.clear > 0:  # just through a doorway: into the room first
            self.clear -= 1
            return self.toward(obs, 0.0, 1.0)
        # time in a room in proportion to how likely what it wants is in a room of its type
        t = self.doorways.type_index(self.room_type or None)
        share = 1.0 if t is None or self.loose() else float(self.want_types(obs)[t])
        patience = max(MIN_PATIENCE, ROOM_PATIENCE * share) / (3 if self.revisit else 1)
        if not self.leaving(obs) and self.in_room < patience:
            place = self.promising(obs, dets)
            self.place = None if place is None else place["id"]
            if place is not None:  # go and look at it from close up
                if place["kind"] == "container" and place["state"] == "closed":
                    if place["dist"] <= SIZES.get(place["category"], 0.5) + 0.55 and \
                            abs(place["bearing"]) < 0.6:
                        return {"primitive": "open", "target": place["id"]}
                    if abs(place["bearing"]) > 0.6:
                        return {"primitive": "move", "move": [
                            0.0, max(-1.0, min(1.0, place["bearing"] / (math.pi / 4)))]}
                return self.toward(obs, place["bearing"], place["dist"])
            if self.scan < SCAN:  # look around
                self.scan += 1
                return {"primitive": "move", "move": [0.0, 1.0]}
            if self.roam == 0 and self.roams < ROAMS:
                self.roam, self.roams = ROAM, self.roams + 1
            if self.roam > 0:  # into the open part of the room, then look around again
                self.roam -= 1
                if self.roam == 0:
                    self.scan = SCAN // 2
                return self.toward(obs, self.open_bearing(obs, dets), 2.0)
        return self.leave(obs, dets)

    @staticmethod
    def open_bearing(obs: dict, dets: list[dict]) -> float:
        """The bearing of the longest free ray of the range scan within the view (where the
        room opens up), leaving out rays through a doorway in view (that is another
        room)."""
        scan = np.asarray(obs["range_scan"], float)
        rays = np.remainder(np.arange(len(scan)) * (2 * math.pi / len(scan)) + math.pi,
                            2 * math.pi) - math.pi
        ok = np.abs(rays) <= math.pi / 3 + 1e-6
        for door in dets:
            if door["kind"] == "door":
                width = math.atan2(0.7, max(door["dist"], 0.3)) + 0.1
                ok &= np.abs(np.remainder(rays - door["bearing"] + math.pi, 2 * math.pi)
                             - math.pi) > width
        if not ok.any():
            return math.pi / 2
        room = np.minimum(scan, 5.0) - 0.5 * np.abs(rays)  # ties: the straighter
        return float(rays[int(np.argmax(np.where(ok, room, -9.0)))])

    def leave(self, obs: dict, dets: list[dict]) -> dict[str, Any]:
        """Out through the doorway in view that most likely leads toward what is wanted
        (the learned doorway model), never back through the one it came in by while another
        is in view; with none in view it turns to find one, then follows the walls."""
        doors = [d for d in dets if d["kind"] == "door" and d["id"] not in self.locked
                 and self.through(d, dets) is None]
        if self.door is not None and self.passing > 0 and not any(
                d["id"] == self.door for d in doors):
            self.passing -= 1  # in the doorway: it is out of view, carry on through
            return self.toward(obs, 0.0, 1.0)
        if doors:
            want = self.want_types(obs)
            furniture = [d for d in dets if d["kind"] in ("furniture", "container")]

            def value(door: dict) -> float:
                seen = [f["category"] for f in furniture
                        if (self.through(f, dets) or {}).get("id") == door["id"]]
                v = self.doorways.value(self.room_type or None, seen, want)
                if door["id"] == self.entry:
                    v *= 0.15
                if door["id"] == self.door:
                    v *= 1.5  # keeps to its choice
                return v / (1 + door["dist"] / 8)

            door = max(doors, key=value)
            if door["id"] == self.entry and self.in_room < BACK:
                # only the way back in view: look around for another, then along the walls
                if self.scan < SCAN:
                    self.scan += 1
                    return {"primitive": "move", "move": [0.0, 1.0]}
                return self.follow_wall(obs, dets)
            self.door = door["id"]
            self.scan = SCAN
            if door["state"] == "closed":
                if door["dist"] < 1.45 and abs(door["bearing"]) < 0.6:
                    return {"primitive": "open", "target": door["id"]}
                return self.toward(obs, door["bearing"], door["dist"])
            if door["dist"] < 1.2:
                self.passing = 3
            return self.toward(obs, door["bearing"], door["dist"] + 1.0)
        # No way out in view: look all round for one, then along the walls, and look
        # round again after a while (the searching turns looked for furniture, and a
        # 120-degree view along a wall misses a doorway behind it).
        phase = self.door_scan % (SCAN + WALL_STEPS)
        self.door_scan += 1
        if phase < SCAN:
            return {"primitive": "move", "move": [0.0, 1.0]}
        return self.follow_wall(obs, dets)

    def leaving(self, obs: dict) -> bool:
        """Whether the goal names another room than this one, or names none and what is
        wanted is unlikely in a room of this type (the learned priors)."""
        room = self.room_wanted(obs)
        if room is not None:
            return bool(self.room_type and self.room_type != room)
        if self.loose() or not self.room_type:
            return False
        t = self.doorways.type_index(self.room_type)
        return t is not None and float(self.want_types(obs)[t]) < UNLIKELY

    def room_wanted(self, obs: dict) -> str | None:
        """The room type the goal names for what is needed next, if any (for the thing to
        fetch, until it takes the description loosely)."""
        goal = self.goals[self.current]
        if self.fetching(obs):
            ref = goal["item"] if goal["kind"] == "place" else goal["tool"]
            return None if self.loose() else ref.get("room")
        return (goal["dest"] if goal["kind"] == "place" else goal["target"]).get("room")

    def failure(self, ts: TimeStep, stage: str) -> None:
        """A failed action that says what is wrong: a locked door, an unusable container."""
        result = ts.observation["action_result"]
        self.nudge = None
        if self.last is None or result.get("ok", True):
            return
        reason, target = result.get("reason"), self.last.get("target")
        if reason == "blocked_by_robot":  # standing in the door's way: step back
            self.nudge = {"primitive": "move", "move": [-0.6, 0.0]}
            return
        if reason == "out_of_reach" and self.last["primitive"] in ("open", "close"):
            self.nudge = {"primitive": "move", "move": [0.4, 0.0]}
            return
        if self.last["primitive"] == "place" and reason in ("receptacle_full",
                                                            "not_a_receptacle"):
            if target not in self.refused:
                self.refused.append(target)
            return
        if reason == "locked":
            if target not in self.locked:
                self.locked.append(target)
            kind = "door_lock"
        elif reason == "unavailable":
            if target not in self.unusable:
                self.unusable.append(target)
            kind = "container_unavailable"
        else:
            return
        if stage == "execution" and kind not in self.logged:
            self.logged.add(kind)
            self.record("exception_detected", stage, kind, target=target)

    # ------------------------------------------------------------------ the loop
    def run(self, env: RemoteEnv) -> None:
        env.hello(agent="eagc-track1-memoryfree/3")
        ts: TimeStep = env.reset()
        self.nudge: dict[str, Any] | None = None
        self.lock: tuple | None = None
        while not ts.episode_over:
            obs = ts.observation
            if ts.stage != self.stage:
                self.stage = ts.stage
                self.new_stage()
                if ts.stage == "execution":
                    self.budget = ts.steps_left or 0
            self.in_room += 1
            self.stuck = self.stuck + 1 if int(obs["collided"][0]) else 0
            dets = self.seen(obs)
            near = [d for d in dets if d["kind"] == "door" and d["dist"] < 1.5]
            if near:
                self.near_door = min(near, key=lambda d: d["dist"])["id"]
            if int(obs["room"][0]) >= 0 and int(obs["room"][0]) != self.room:
                room = int(obs["room"][0])
                self.new_room(room, obs["room_name"], revisit=room in self.recent)
            elif self.room < 0 and not self.room_type:
                self.room_type = self.recognise(dets)
            for m in ts.messages:
                if m.type == "instruction" and "text" in m.data:
                    self.goals = parse(m.data["text"])
            self.failure(ts, ts.stage)
            if self.nudge is not None and ts.stage != "planning" and not (
                    ts.steps_left is not None and ts.steps_left <= 1):
                action = self.nudge
            elif ts.stage == "exploration":
                self.write_model(obs)
                if ts.steps_left is not None and ts.steps_left <= 1:
                    ts = env.end_stage()
                    continue
                action = self.wander(obs, dets)
            elif ts.stage == "planning":
                queries = next((m.data["queries"] for m in ts.messages if m.type == "queries"),
                               [])
                visible = {d["id"]: d for d in dets}
                rooms = self.answers.named_rooms(queries)
                if self.room >= 0 and self.room_type:
                    rooms[self.room] = self.room_type
                answers = {q["id"]: a for q in queries
                           if (a := self.answers.answer(q, rooms, visible)) is not None}
                if answers:
                    ts = env.answer(answers)
                self.record("plan", ts.stage, goals=self.goals)
                ts = env.end_stage({"plan": {"subgoals": []}})
                continue
            else:
                self.exec_steps += 1
                if self.current >= len(self.goals) or (ts.steps_left is not None
                                                       and ts.steps_left <= 1):
                    action = {"primitive": "done"}
                else:
                    action = self.act(obs, dets, ts.stage)
            self.step += 1
            self.last = action
            ts = env.step(action)
            if (action["primitive"] in ("place", "use") and ts.action is not None
                    and ts.action.ok and self.current < len(self.goals)):
                if self.drop:
                    self.drop = False
                    continue
                done = self.goals[self.current]
                self.current += 1
                self.exec_steps = 0
                if done["kind"] == "use" and self.current < len(self.goals):
                    nxt = self.goals[self.current]
                    self.drop = nxt["kind"] != "place" or nxt["item"] is not done["tool"]
        self.write_model(ts.observation)
        self.record("note", ts.stage, end=ts.end_reason)


if __name__ == "__main__":
    sys.exit(main(Agent))
