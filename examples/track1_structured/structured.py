"""The structured world model planner (paper Table IV, "Structured WM + replanning"): the
look-ahead planner augmented with

- an object inventory with uncertainty: the position is the inverse-variance mean of the
  sightings (noise grows with distance), restarted when the thing is seen far from where
  it was, and every sighting votes for its category and colour with the same weight (a
  detector reads some things as a look-alike from afar, the same way every time: one
  close look outweighs many distant ones);
- a queryable topology and inventory: every query is answered, from the model when it
  knows, else from the learned priors (the most likely room for an item's category, the
  likeliest state of a door or container);
- an affordance table (which categories can wipe, cut, water), so that a missing tool is
  replaced at once by the nearest known tool with the same use, else searched for as any
  tool with that use;
- exception-triggered replanning on evidence, not on a single missed detection: an item
  counts as gone only after it was not detected from close up, facing its place in clear
  view, three times. A vanished item of a place goal is relocated: followed by its instance
  id, searched for at the backup places the rules allow (``vanish``, ``backup``), then
  where it was; one never seen and missing where the instruction puts it is taken for
  relocated too. A failed ``open`` or ``place`` marks the door locked or the container
  unavailable, and the route or the destination is replanned at once;
- descriptions matched on the room of what a thing rests on (a piece of furniture is seen
  from its own room much more often than a small item is): category, colour and a named
  room must fit, what it rests on breaks ties.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

from lookahead import LookaheadPlanner

from simhost.client import TimeStep
from simhost.client.skills import AFFORDANCES, Thing, WorldModel, face, reach_radius

NOISE = (0.02, 0.03)
"""Position noise of a detection, a + b × distance (m): the official splits' sensor."""
GONE_LOOKS = 3
"""Looks at an item's place in clear view, from close up, without the item, before it counts
as gone (a detection is missed about one time in eight there)."""
DOOR_PRIOR, CONTAINER_PRIOR = "open", "closed"
"""The likelier state of a door and of a container that was never seen."""
BACKUP_FURNITURE = ("cabinet", "drawer")
"""Where a relocated item can be put away besides the storage room (the track's rules)."""
SEEN_ELSEWHERE = 0.05
"""What a backup place still counts for once looked at since the item vanished."""


class Lost:
    """An item that vanished from its place (a relocation): its id when it had been seen
    (``None``: never seen, missing from where the instruction puts it), the rooms it is not
    in and the things already known when it vanished (a look-alike among them is not it)."""

    def __init__(self, item: int | None, rooms: set[int], known: set[int]) -> None:
        self.item, self.rooms, self.known = item, rooms, known


class StructuredModel(WorldModel):
    """The heuristic's model with fused sightings (see the module)."""

    def __init__(self) -> None:
        super().__init__()
        self.votes: dict[int, dict[tuple[str, str], float]] = {}  # label -> weight
        self.fused: dict[int, tuple[float, float, float]] = {}  # x·w, y·w, w

    def observe(self, pose: tuple[float, float, float], room: int, room_type: str,
                detections: list[dict[str, Any]], step: int) -> list[Thing]:
        seen = super().observe(pose, room, room_type, detections, step)
        moved = {t.id for t in self.moved}
        for d in detections:
            t = self.things[d["id"]]
            if t.id in moved:  # far from where it was: a new place, start again
                self.fused.pop(t.id, None)
            sigma = NOISE[0] + NOISE[1] * math.hypot(*d["rel_pos"])
            w = 1.0 / (sigma * sigma)
            sx, sy, sw = self.fused.get(t.id, (0.0, 0.0, 0.0))
            self.fused[t.id] = (sx + w * t.position[0], sy + w * t.position[1], sw + w)
            sx, sy, sw = self.fused[t.id]
            t.position = (sx / sw, sy / sw)
            votes = self.votes.setdefault(t.id, {})
            label = (d["category"], d["colour"])
            votes[label] = votes.get(label, 0.0) + w
            t.category, t.colour = max(votes, key=votes.__getitem__)
        return seen


class StructuredPlanner(LookaheadPlanner):
    """The look-ahead planner with a structured world model (see the module)."""

    name = "eagc-track1-structured/1"

    def __init__(self) -> None:
        super().__init__()
        self.model = StructuredModel()
        self.nav.model = self.model
        self.nav.horizon = 40
        self.looks: Counter[int] = Counter()
        self.lost: dict[int, Lost] = {}  # goal index -> the item that vanished from its place
        self.hunt: tuple[str, Any] | None = None  # what ``seek`` looks for anywhere
        self.widened: set[int] = set()  # goals whose backup places were all looked at

    # ------------------------------------------------------------------ descriptions
    def room_of(self, t: Thing) -> int | None:
        """A thing's room: for an item, the room of what it rests on when that is known (a
        piece of furniture is seen from its own room much more often than an item)."""
        base = self.model.on_what(t) if t.kind in ("object", "tool") else None
        return self.model.room_of(base if base is not None else t)

    def pick(self, ref: dict[str, Any], things: list[Thing]) -> list[Thing]:
        """The things that fit a description, best first: category and colour must fit, and
        the room when the description names one (look-alikes stand in other rooms); what it
        rests on, then distance, break ties. A thing of unknown room fits, ranked last."""
        m = self.model
        out = []
        for t in things:
            if t.gone or t.category != ref["category"]:
                continue
            if ref.get("colour") and t.colour != ref["colour"]:
                continue
            room_type = m.rooms.get(self.room_of(t))
            if ref.get("room") and room_type is not None and room_type != ref["room"]:
                continue
            unknown = int(bool(ref.get("room")) and room_type is None)
            base = m.on_what(t)
            on = 0 if not ref.get("on") else (0 if base and base.category == ref["on"] else 1)
            out.append((unknown, on, math.dist(t.position, self.pose[:2]), t))
        return [t for *_k, t in sorted(out, key=lambda x: x[:3])]

    def relocated(self, ref: dict[str, Any], lost: Lost) -> list[Thing]:
        """A vanished item: the very thing when it had been seen (instance ids persist; the
        description's room or what it rested on no longer hold), else a thing that fits the
        category and colour, found since, outside the rooms it was missing from."""
        m = self.model
        if lost.item is not None:
            t = m.things.get(lost.item)
            return [] if t is None or t.gone else [t]
        return sorted((t for t in m.of_kind("object", "tool") if not t.gone
                       and t.id not in lost.known and t.category == ref["category"]
                       and (not ref.get("colour") or t.colour == ref["colour"])
                       and self.room_of(t) not in lost.rooms),
                      key=lambda t: math.dist(t.position, self.pose[:2]))

    def goal_index(self, goal: dict[str, Any]) -> int:
        return next((k for k, g in enumerate(self.goals) if g is goal), -1)

    def resolve(self, goal: dict[str, Any]) -> tuple[Thing | None, Thing | None]:
        m = self.model
        ref = goal["item"] if goal["kind"] == "place" else goal["tool"]
        lost = self.lost.get(self.goal_index(goal))
        items = (self.relocated(ref, lost) if lost is not None
                 else self.pick(ref, m.of_kind("object", "tool")))
        if goal["kind"] == "use" and not items and (
                "tool_substitution" in self.reported or self.exhausted):
            items = sorted((t for t in m.of_kind("tool") if not t.gone
                            and AFFORDANCES.get(t.category) == goal["affordance"]),
                           key=lambda t: math.dist(t.position, self.pose[:2]))
        if self.held >= 0 and any(t.id == self.held for t in items):
            items = [m.things[self.held]]
        if goal["kind"] == "use":
            dests = self.pick(goal["target"], list(m.things.values()))
        else:
            dests = [t for t in self.pick(goal["dest"], m.of_kind("furniture", "container"))]
            if dests and dests[0].state == "unavailable":  # another container of that room
                room = m.room_of(dests[0])
                dests = sorted((t for t in m.of_kind("container") if m.room_of(t) == room
                                and t.state != "unavailable" and t.id not in self.full),
                               key=lambda t: math.dist(t.position, self.pose[:2]))
        return (items[0] if items else None), (dests[0] if dests else None)

    # ------------------------------------------------------------------ evidence
    def fetch(self, item: Thing, ts: TimeStep) -> dict[str, Any] | None:
        """Fetches an item; it is gone only after ``GONE_LOOKS`` close looks at its place
        without it."""
        box = self.box_of(item)
        if box is not None and box.state == "closed":
            return self.act_on(box, "open")
        dx, dy = item.position[0] - self.pose[0], item.position[1] - self.pose[1]
        bearing = math.remainder(math.atan2(dy, dx) - self.pose[2], math.tau)
        base = self.model.on_what(item)
        close = math.hypot(dx, dy) <= 2.2 and abs(bearing) < 0.8 and (
            base is None or base.id in self.seen_now) and self.model.doorway_between(
            self.pose[:2], item.position, exclude=-1) is None  # its place in clear view
        if close and item.id not in self.seen_now:
            self.looks[item.id] += 1
        elif item.id in self.seen_now:
            self.looks[item.id] = 0
        if self.looks[item.id] >= GONE_LOOKS:
            self.looks[item.id] = 0
            item.gone = True
            self.vanish(item, ts.stage)
            return self.seek(ts)
        if close and item.id not in self.seen_now:  # look again, squarely
            turn = face(self.pose, item.position, 0.2)
            if turn is not None:
                return turn
            return {"primitive": "move", "move": [0.0, 0.3 if self.looks[item.id] % 2 else
                                                  -0.3]}
        return self.act_on(item, "pick")

    # ------------------------------------------------------------------ replanning
    def vanish(self, item: Thing | None, stage: str) -> None:
        """The current goal's item is not where the model (or the instruction) put it: for
        a place goal a relocation (search the backup places, nearest and likeliest first,
        the old place marked searched-empty), for a tool a substitution (another tool of
        the same use, known or searched for)."""
        k = self.done_goals
        goal = self.goals[k]
        if goal["kind"] == "use":
            self.report("tool_substitution", stage, item=None if item is None else item.id)
            return
        m = self.model
        if item is not None:
            rooms = {m.room_of(item)} - {None}
        else:  # never seen: missing from the room the instruction names, if any
            named = goal["item"].get("room")
            rooms = {r for r, t in m.rooms.items() if named is not None and t == named}
        self.lost[k] = Lost(None if item is None else item.id, rooms, set(m.things))
        self.report("object_relocation", stage, item=None if item is None else item.id)
        # A look at a backup place before the item vanished says nothing about it now.
        self.inspected -= {t.id for t in m.of_kind("furniture", "container") if self.backup(t)}
        self.seek_target = None

    def backup(self, t: Thing) -> bool:
        """Whether a relocated item can be on or in ``t`` (the storage room, or a cabinet or
        drawer elsewhere; never the room it vanished from)."""
        lost = self.lost.get(self.done_goals)
        room = self.model.room_of(t)
        if lost is not None and room in lost.rooms:
            return False
        return self.model.rooms.get(room) == "storage" or t.category in BACKUP_FURNITURE

    def wanted(self) -> tuple[str, str | None] | None:
        """As the look-ahead planner; a vanished item or a substituted tool is wanted
        anywhere (``self.hunt`` says which)."""
        self.hunt = None
        k = self.done_goals
        if k < len(self.goals):
            goal = self.goals[k]
            item, _dest = self.resolve(goal)
            if item is None and k in self.lost:
                self.hunt = ("lost", k)
                return goal["item"]["category"], None
            if item is None and goal["kind"] == "use" and "tool_substitution" in self.reported:
                self.hunt = ("tool", goal["affordance"])
                return goal["tool"]["category"], None
        return super().wanted()

    def place_value(self, t: Thing, category: str, room: str | None) -> float:
        hunt = self.hunt
        if hunt is not None and hunt[0] == "lost":
            if not self.backup(t):
                return 0.0
            if t.kind == "container" and t.state == "closed":
                return 1.0
            return SEEN_ELSEWHERE if t.id in self.inspected else 1.0
        if hunt is not None and hunt[0] == "tool":
            return max(super(StructuredPlanner, self).place_value(t, c, None)
                       for c, a in AFFORDANCES.items() if a == hunt[1])
        return super().place_value(t, category, room)

    def unexplored_value(self, category: str, room: str | None) -> float:
        hunt = self.hunt
        if hunt is not None and hunt[0] == "lost":  # the storage room, or a cabinet or drawer
            return 0.5 if "storage" in self.model.rooms.values() else 1.0
        if hunt is not None and hunt[0] == "tool":
            return max(super(StructuredPlanner, self).unexplored_value(c, None)
                       for c, a in AFFORDANCES.items() if a == hunt[1])
        return super().unexplored_value(category, room)

    def execute(self, ts: TimeStep) -> dict[str, Any] | None:
        """As the map planner; when the goal's item cannot be found where the model and the
        instruction put it, that is the exception's sign: replan as for a vanished item
        (once), instead of giving up; when no backup place has it either, look again where
        it was (the looks that found it gone may have missed it)."""
        k = self.done_goals
        if (k < len(self.goals) and self.exhausted and self.goals[k]["kind"] == "use"
                and not self.pick(self.goals[k]["tool"], self.model.of_kind("tool"))):
            self.vanish(None, ts.stage)  # the named tool is nowhere: a substitute, say so
        act = super().execute(ts)
        if (act is not None or self.done_goals >= len(self.goals)
                or (ts.steps_left is not None and ts.steps_left <= 1)):
            return act
        k = self.done_goals
        goal = self.goals[k]
        item, _dest = self.resolve(goal)
        if item is None and goal["kind"] == "place" and k not in self.widened:
            if k not in self.lost:
                self.vanish(None, ts.stage)
            else:  # no backup place has it: it may never have left (a missed detection)
                rooms = self.lost.pop(k).rooms
                self.widened.add(k)
                self.inspected -= {t.id for t in self.model.of_kind("furniture", "container")
                                   if self.model.room_of(t) in rooms}
                self.seek_target = None
            self.exhausted = False
            return super().execute(ts)
        return act

    # ------------------------------------------------------------------ queries
    def answers(self) -> dict[str, Any]:
        """Every query answered: from the model where it knows, else from the priors."""
        m = self.model
        out: dict[str, Any] = {}
        for q in self.queries:
            known = m.answer(q)
            if known is not None:
                out[q["id"]] = known
                continue
            kind = q["kind"]
            if kind == "object_room":
                guess = self.priors.room_of(q["category"], m.rooms)
            elif kind == "door_state":
                guess = DOOR_PRIOR
            elif kind == "container_state":
                guess = CONTAINER_PRIOR
            elif kind == "object_count":
                guess = 1
            else:
                guess = None
            if guess is not None:
                out[q["id"]] = guess
        return out

    def plan(self, env: Any, ts: TimeStep) -> TimeStep:
        """Answers every query, then plans as the map planner does."""
        answers = self.answers()
        self.queries = []  # answered here
        if answers:
            ts = env.answer(answers)
            self.record("note", ts.stage, answered=len(answers))
        return super().plan(env, ts)

    def act_on(self, thing: Thing, primitive: str, **extra: Any) -> dict[str, Any] | None:
        if primitive == "pick" and math.dist(thing.position, self.pose[:2]) > reach_radius(
                thing) + 1.0:
            self.looks[thing.id] = 0
        return super().act_on(thing, primitive, **extra)
