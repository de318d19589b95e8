"""The look-ahead planner (paper Table IV, in the spirit of PathDreamer): the heuristic map
planner, but it predicts what unvisited viewpoints would show, from priors learned offline on
generated houses (``priors.py``), and goes where the prediction is worth the steps.

- Exploration: every candidate is valued by what it is expected to reveal, over its cost in
  steps: the room behind an unexplored doorway (the expected number of things in a room of
  the types likely to adjoin this one), a frontier of the range-scan map (as much, scaled by
  the unknown share around it), a close look at a piece of furniture seen only from afar
  (small things are detected within 3 m only: part of the expected number of things on
  it), a closed container (the expected number shut inside).
- Execution: when the goal's item or place is not in the map, it looks where it most likely
  is per step of cost: a piece of furniture by the priors (furniture category and room
  type; opening a closed container; the storage room, cabinets and drawers for an item that
  vanished), or a room not visited yet (how much of the category's rooms are still
  unseen).

Everything else (mapping, navigation, model, instructions, exceptions) is the heuristic
planner's (``planner.py``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from planner import MapPlanner
from priors import Priors

from simhost.client import TimeStep
from simhost.client.skills import DoorOpener, Thing, door_normal, face, near

CLOSE = 2.3
"""Within this distance, facing it, a piece of furniture has been looked at closely."""
VIEW = 1.6
"""Where to stand to look at a piece of furniture."""
FRONTIER_VALUE = 1.0
UNSEEN_ON_IT = 0.5
"""Share of the things on a piece of furniture a close look is expected to add (some were
seen from afar already)."""
SHUT_AWAY = 0.7


class LookaheadPlanner(MapPlanner):
    """The map planner with learned look-ahead (see the module)."""

    name = "eagc-track1-lookahead/1"

    def __init__(self) -> None:
        super().__init__()
        self.priors = Priors()
        self.inspected: set[int] = set()
        self.spins = 0
        self.seek_target: tuple | None = None
        self.seek_for: tuple[str, str | None] | None = None
        self.vanished = False

    # ------------------------------------------------------------------ perception
    def perceive(self, ts: TimeStep) -> None:
        super().perceive(ts)
        for d in ts.observation["detections"]:
            x, y = d["rel_pos"]
            if (d["kind"] in ("furniture", "container") and math.hypot(x, y) < CLOSE
                    and abs(math.atan2(y, x)) < 0.9):
                self.inspected.add(d["id"])

    # ------------------------------------------------------------------ exploration
    def next_goal(self) -> tuple | None:
        """The candidate with the most expected discovery per step."""
        dist, lo = self.grid.distance_field(self.pose[:2])
        h, w = dist.shape

        def steps(p: tuple[float, float]) -> float | None:
            i, j = self.grid.cell(*p)
            i, j = i - lo[0], j - lo[1]
            if 0 <= i < h and 0 <= j < w and dist[i, j] >= 0:
                return float(dist[i, j]) / 5.0  # 0.1 m cells, 0.5 m per move
            return None

        options: list[tuple[float, tuple]] = []
        behind = self.priors.items_behind(self.room_type or None)
        for door in self.model.of_kind("door"):
            if door.state != "closed" or door.id in self.failed:
                continue
            nx, ny = door_normal(self.grid, door, self.pose)
            beyond = [self.grid.cell(door.position[0] + s * 1.2 * nx,
                                     door.position[1] + s * 1.2 * ny) for s in (-1, 1)]
            if all(self.grid.known[c] for c in beyond) and len(self.model.door_rooms(door.id)) == 2:
                continue
            opener = DoorOpener(self.grid, self.model, door)
            cost = steps(opener.stand(self.pose))
            if cost is not None:
                options.append((behind / (cost + 4), ("door", door.id, opener)))
        for t in self.model.of_kind("furniture", "container"):
            cost = steps(t.position) if t.id not in self.failed else None
            if cost is None:
                continue
            if t.kind == "container" and t.state == "closed":
                value = self.priors.items_on(t.category) * self.priors.hidden(t.category)
                options.append((SHUT_AWAY * value / (cost + 4), ("container", t.id)))
            elif t.id not in self.inspected:
                value = self.priors.items_on(t.category) * (1 - self.priors.hidden(t.category))
                options.append((UNSEEN_ON_IT * value / (cost + 3), ("view", t.id)))
        frontier = self.frontier_goal(dist, lo)
        if frontier is not None:
            cost, point, unknown = frontier
            value = FRONTIER_VALUE + unknown * behind  # a room's worth behind a big frontier
            options.append((value / (cost / 5.0 + 2), ("frontier", point)))
        if not options:
            return None
        # Coverage first: a close look or a container only when clearly worth more than the
        # next doorway or frontier (they open whole rooms to the range scan and the camera).
        reach = [o for o in options if o[1][0] in ("door", "frontier")]
        look = [o for o in options if o[1][0] not in ("door", "frontier")]
        best_reach = max(reach, key=lambda o: o[0], default=None)
        best_look = max(look, key=lambda o: o[0], default=None)
        if best_reach is not None and (best_look is None or best_look[0] < 2 * best_reach[0]):
            best = best_reach[1]
        else:
            assert best_look is not None
            best = best_look[1]
        if best[0] == "door":
            self.opener = best[2]
        return best

    def frontier_goal(self, dist: np.ndarray, lo: np.ndarray
                      ) -> tuple[int, tuple[float, float], float] | None:
        """The nearest frontier of the range-scan map worth going to (as the heuristic): its
        cost (grid cells), where it is, and the unknown share of the 4 m around it."""
        frontier = self.frontiers(dist, lo)
        if not frontier.any():
            return None
        cells = np.argwhere(frontier)
        k = int(np.argmin(dist[frontier]))
        i, j = int(cells[k][0]), int(cells[k][1])
        around = ~self.grid.known[max(0, i + lo[0] - 20):i + lo[0] + 21,
                                  max(0, j + lo[1] - 20):j + lo[1] + 21]
        return (int(dist[frontier][k]), self.grid.point(i + lo[0], j + lo[1]),
                float(around.mean()))

    def explore(self, ts: TimeStep) -> dict[str, Any] | None:
        """Spends the whole exploration budget: goals that give no action are set aside; with
        nothing left to go to it looks around where it stands (a full turn, then it ends)."""
        if ts.steps_left is not None and ts.steps_left <= 2:
            return None
        for _ in range(10):
            if self.goal is None:
                self.goal = self.next_goal()
                if self.goal is None:
                    break
            act = self.pursue()
            if act is not None:
                return act
            self.set_aside(self.goal)
            self.goal = None
        self.spins += 1
        return {"primitive": "move", "move": [0.0, 1.0]} if self.spins <= 8 else None

    def set_aside(self, goal: tuple) -> None:
        """A goal that gave no action is not chosen again."""
        kind, subject = goal[0], goal[1]
        if kind == "frontier":
            self.blacklist.append(subject)
        elif kind == "view":
            self.inspected.add(subject)
        else:
            self.failed.add(subject)

    def pursue(self) -> dict[str, Any] | None:
        assert self.goal is not None
        if self.goal[0] != "view":
            return super().pursue()
        return self.look_at(self.model.things[self.goal[1]])

    def look_at(self, thing: Thing) -> dict[str, Any] | None:
        """Goes near a piece of furniture and faces it; None once it has been looked at."""
        if thing.id in self.inspected:
            return None
        goal = self.in_room(near(thing.position, VIEW), self.model.room_of(thing))
        act = self.nav.go(("view", thing.id), goal, self.pose, self.collided)
        if isinstance(act, dict):
            return act
        turn = face(self.pose, thing.position, 0.4)
        if turn is not None and self.turns < 4:
            self.turns += 1
            return turn
        self.turns = 0
        self.inspected.add(thing.id)  # looked at as well as it can be from here
        if act == "unreachable":
            self.failed.add(thing.id)
        return None

    # ------------------------------------------------------------------ execution
    def wanted(self) -> tuple[str, str | None] | None:
        """What the current goal needs next that the map does not hold: (category, the room
        type the instruction names for it, if any)."""
        if self.done_goals >= len(self.goals):
            return None
        goal = self.goals[self.done_goals]
        item, _dest = self.resolve(goal)
        ref = goal["item"] if goal["kind"] == "place" else goal["tool"]
        if item is None:
            return ref["category"], ref.get("room")
        target = goal["dest"] if goal["kind"] == "place" else goal["target"]
        return target["category"], target.get("room")

    def search_targets(self, backup_first: bool) -> list[int]:
        """Kept for the map planner's callers: the search itself is ``seek``."""
        return []

    def report(self, kind: str, stage: str, **data: Any) -> None:
        if kind == "object_relocation":
            self.vanished = True
        self.seek_target = None
        super().report(kind, stage, **data)

    def place_value(self, t: Thing, category: str, room: str | None) -> float:
        """How likely what is wanted is on or in a piece of furniture, as far as a look or
        an opening has not ruled it out."""
        room_type = self.model.rooms.get(self.model.room_of(t))
        if room is not None and room_type is not None and room_type != room:
            return 0.0
        p = self.priors.where(category, t.category, room_type)
        if self.vanished and (room_type == "storage" or t.category in ("cabinet", "drawer")):
            p += 0.2  # a vanished item is in a backup place
        if t.kind == "container" and t.state == "closed":
            return p
        return 0.1 * p if t.id in self.inspected else p

    def unexplored_value(self, category: str, room: str | None) -> float:
        """How likely what is wanted is in a room not visited yet."""
        visited = set(self.model.rooms.values())
        if room is not None:
            return 0.0 if room in visited else 1.0
        known = self.priors.tables["category_room"]
        c = self.priors.items.index(category) if category in self.priors.items else None
        if c is None:
            return 0.3
        seen = sum(known[c][self.priors.room_types.index(t)] for t in visited
                   if t in self.priors.room_types)
        return max(0.0, 1.0 - seen)

    def seek(self, ts: TimeStep) -> dict[str, Any] | None:
        """Looks where what is wanted most likely is, per step cost: known furniture by the
        learned priors (opening closed containers), or unexplored rooms."""
        want = self.wanted()
        if want is None:
            return None
        category, room = want
        if self.seek_target is not None and self.seek_for == want:
            act = self.pursue_seek()
            if act is not None:
                return act
        self.seek_for = want
        options: list[tuple[float, tuple]] = []
        for t in self.model.of_kind("furniture", "container"):
            if t.id in self.failed:
                continue
            p = self.place_value(t, category, room)
            if p > 0.01:
                cost = math.dist(t.position, self.pose[:2]) / 0.5 + 4
                options.append((p / cost, ("place", t.id)))
        goal = self.next_goal()
        if goal is not None and goal[0] in ("door", "frontier"):
            p = self.unexplored_value(category, room)
            where = (self.model.things[goal[1]].position if goal[0] == "door" else goal[1])
            cost = math.dist(where, self.pose[:2]) / 0.5 + 6
            options.append((p / cost, goal))
        if not options:
            return None
        self.seek_target = max(options, key=lambda o: o[0])[1]
        if self.seek_target[0] == "door":
            self.opener = self.seek_target[2]
        return self.pursue_seek()

    def pursue_seek(self) -> dict[str, Any] | None:
        """The next action toward the search target; None (and no target) once done."""
        target = self.seek_target
        assert target is not None
        if target[0] in ("door", "frontier"):
            self.goal = target
            act = self.pursue()
            if act is None:
                self.set_aside(target)
                self.seek_target = self.goal = None
            return act
        t = self.model.things[target[1]]
        if t.kind == "container" and t.state == "closed":
            act = self.act_on(t, "open")
            if act is not None:
                return act
        act = self.look_at(t)
        if act is None:
            self.seek_target = None
        return act
