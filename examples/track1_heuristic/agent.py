"""Track 1 heuristic map planner baseline (paper Table IV): what a team can start from.

- Exploration: an occupancy grid from the range scan; goes to the nearest frontier, opens
  closed doors with unexplored space behind them and closed containers (to see inside);
  keeps rooms, door connectivity, door/container states and objects in a world model
  (``model.py``), written to ``/output/world_model.json`` before the stage ends.
- Planning: parses the instruction (the track's templates), answers the queries from the
  model, and submits a plan: the instruction's steps, the room route and the doors its
  breadth-first grid paths cross.
- Execution: fetches the item, then places it or uses it on the target, re-planning as the
  map changes. Exceptions: a locked door or an unavailable container is seen in the
  detections; a missing item is noticed where the model put it. Each is logged
  (``exception_detected``), the model is updated and written, and the plan adapts: a detour,
  a search (the storage room first), a substitute container in the same room or another
  tool with the same use.

Uses only ``simhost.agent.RemoteEnv``, numpy and the standard library.
"""

from __future__ import annotations

import json
import math
import os
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np
from mapping import Grid
from model import AFFORDANCES, Thing, WorldModel
from skills import DoorOpener, Navigator, door_normal, facing, near, reach_radius

from simhost.agent import RemoteEnv, TimeStep

OUT = Path(os.environ.get("EAGC_OUTPUT", "/output"))
ROOM_WORDS = {"living room": "living_room", "storage room": "storage"}


def parse_instruction(text: str) -> dict[str, Any] | None:
    """The track's instruction templates, back to names."""
    def name(words: str) -> str:
        return ROOM_WORDS.get(words, words.replace(" ", "_"))

    m = re.match(r"(?:put|place) the (\w+) (.+?) (in|on) the (.+?) in the (.+)$", text)
    if m:
        return {"kind": "place", "item": (name(m[2]), m[1]), "dest": (name(m[4]), name(m[5]))}
    m = re.match(r"(clean|slice|water) the (.+?) with the (\w+) (.+)$", text)
    if m:
        target = m[2]
        where = re.match(r"(.+?) in the (.+)$", target)
        dest = (("place", name(where[1]), name(where[2])) if where
                else ("item", name(target.split(" ", 1)[1]), target.split(" ", 1)[0]))
        return {"kind": "use", "item": (name(m[4]), m[3]), "target": dest,
                "affordance": {"clean": "wipe", "slice": "cut", "water": "water"}[m[1]]}
    return None


class Agent:
    def __init__(self) -> None:
        self.grid = Grid()
        self.model = WorldModel()
        self.nav = Navigator(self.grid, self.model)
        self.step = 0
        self.log = (OUT / "episode_log.jsonl").open("a")
        self.poses: dict[int, list[tuple[float, float]]] = {}
        self.blacklist: list[tuple[float, float]] = []
        self.failed: set[int] = set()
        self.goal: tuple | None = None
        self.opener: DoorOpener | None = None
        self.radius: dict[int, float] = {}
        self.unsided: set[int] = set()
        self.carried: set[int] = set()
        self.full: set[int] = set()
        self.exhausted = False
        self.unseen = 0
        self.last: dict[str, Any] | None = None
        self.seen_now: set[int] = set()
        self.pose = (0.0, 0.0, 0.0)
        self.held = -1
        self.collided = False
        self.instruction: dict[str, Any] | None = None
        self.task: dict[str, Any] | None = None
        self.queries: list[dict[str, Any]] = []
        self.reported: set[str] = set()
        self.search: list[int] = []
        self.searched = False
        self.finished = False

    # ------------------------------------------------------------------ records
    def record(self, event: str, stage: str, exception_type: str | None = None,
               **data: Any) -> None:
        rec: dict[str, Any] = {"step": self.step, "stage": stage, "event": event, "data": data}
        if exception_type:
            rec["exception_type"] = exception_type
        self.log.write(json.dumps(rec) + "\n")
        self.log.flush()

    def report(self, kind: str, stage: str, **data: Any) -> None:
        """An exception noticed: log it, update the model file, say how the plan changes."""
        if kind in self.reported:
            return
        self.reported.add(kind)
        self.record("exception_detected", stage, exception_type=kind, **data)
        self.model.write(OUT)
        self.record("model_update", stage, reason=kind)
        self.record("replan", stage, reason=kind)
        self.nav.reset()

    # ------------------------------------------------------------------ perception
    def perceive(self, ts: TimeStep) -> None:
        obs = ts.observation
        x, y, yaw = (float(v) for v in obs["odometry"])
        self.pose = (x, y, yaw)
        room = int(obs["room"][0])
        self.held = int(obs["held"][0])
        result = obs["action_result"]
        self.collided = bool(result.get("collided"))
        dets = obs["detections"]
        self.seen_now = {d["id"] for d in dets}
        self.grid.scan(x, y, yaw, np.asarray(obs["range_scan"], float))
        if self.collided:  # something the scan missed (a door's edge): block that way
            for a in np.linspace(-0.7, 0.7, 7):
                self.grid.mark(x + 0.34 * math.cos(yaw + a), y + 0.34 * math.sin(yaw + a), 6)
        for t in self.model.observe(self.pose, room, obs["room_name"], dets, self.step):
            if t.kind == "door":
                if t.state == "open":
                    self.grid.clear(*t.position, 0.45)
                else:
                    self.grid.mark(*t.position, 6)
                if t.state == "locked" and ts.stage == "execution":
                    self.report("door_lock", ts.stage, door=t.id)
            elif t.kind == "container" and t.state == "unavailable" and ts.stage == "execution":
                self.report("container_unavailable", ts.stage, container=t.id)
        for t in self.model.moved:  # the agent moves only what it carries
            if ts.stage == "execution" and t.id not in self.carried:
                self.report("object_relocation", ts.stage, item=t.id)
        if self.held >= 0:
            self.carried.add(self.held)
        trail = self.poses.setdefault(room, [])
        if not trail or math.dist(trail[-1], (x, y)) > 0.5:
            trail.append((x, y))
        last = self.last
        if last is not None and last["primitive"] == "place" and result["reason"] in (
                "receptacle_full", "unavailable"):
            self.full.add(last["target"])
        if last is not None and last["primitive"] == "open" and not result["ok"]:
            opener = self.opener or self.nav.door
            if opener is not None and opener.door.id == last["target"]:
                opener.result(result["reason"])
        for message in ts.messages:
            if message.type == "instruction" and "steps" in message.data:
                self.instruction = dict(message.data)
            elif message.type == "queries":
                self.queries = list(message.data.get("queries", []))

    # ------------------------------------------------------------------ exploration
    def explore(self, ts: TimeStep) -> dict[str, Any] | None:
        if (ts.steps_left is not None and ts.steps_left <= 2) or ts.time_left_s < 5:
            return None
        for _ in range(4):
            if self.goal is None:
                self.goal = self.next_goal()
                if self.goal is None:
                    return None
            act = self.pursue()
            if act is not None:
                return act
            self.goal = None
        return None

    def pursue(self) -> dict[str, Any] | None:
        """The next action toward the exploration goal; None when it is over."""
        assert self.goal is not None
        kind, subject = self.goal[0], self.goal[1]
        if kind == "door":
            assert self.opener is not None
            step = self.opener.step(self.pose)
            if isinstance(step, dict):
                return step
            if step == "failed":
                self.failed.add(subject)
            return None
        if kind == "frontier":
            i, j = self.grid.cell(*subject)
            if not self.grid.frontier()[i - 5:i + 6, j - 5:j + 6].any():
                return None  # seen meanwhile
            act = self.nav.go(self.goal, near(subject, 0.3), self.pose, self.collided)
            if isinstance(act, dict):
                return act
            self.blacklist.append(subject)
            return None
        thing = self.model.things[subject]
        if thing.state != "closed":
            self.failed.add(subject)
            return None
        radius = self.radius.get(subject, reach_radius(thing))
        act = self.nav.go((self.goal, radius), near(thing.position, radius), self.pose,
                          self.collided)
        if isinstance(act, dict):
            return act
        if act == "arrived" and radius > 0.5:
            self.radius[subject] = radius - 0.2
            return {"primitive": "open", "target": subject}
        self.failed.add(subject)
        return None

    def next_goal(self) -> tuple | None:
        """The nearest frontier, closed door with unexplored space behind it, or closed
        container, by path length."""
        dist, lo = self.grid.distance_field(self.pose[:2])
        h, w = dist.shape

        def cost(p: tuple[float, float]) -> int | None:
            i, j = self.grid.cell(*p)
            i, j = i - lo[0], j - lo[1]
            if 0 <= i < h and 0 <= j < w and dist[i, j] >= 0:
                return int(dist[i, j])
            return None

        best: tuple[int, tuple] | None = None
        for door in self.model.of_kind("door"):
            if door.state != "closed" or door.id in self.failed:
                continue
            nx, ny = door_normal(self.grid, door, self.pose)
            beyond = [self.grid.cell(door.position[0] + s * 1.2 * nx,
                                     door.position[1] + s * 1.2 * ny) for s in (-1, 1)]
            if all(self.grid.known[c] for c in beyond) and len(self.model.door_rooms(door.id)) == 2:
                continue
            opener = DoorOpener(self.grid, self.model, door)
            c = cost(opener.stand(self.pose))
            if c is not None and (best is None or c < best[0]):
                best = (c, ("door", door.id, opener))
        frontier = self.grid.frontier()[lo[0]:lo[0] + h, lo[1]:lo[1] + w] & (dist >= 0)
        unknown = (~self.grid.known[lo[0]:lo[0] + h, lo[1]:lo[1] + w]).astype(np.int32)
        mass = np.pad(unknown, 5).cumsum(0).cumsum(1)
        window = mass[10:, 10:] - mass[:-10, 10:] - mass[10:, :-10] + mass[:-10, :-10]
        frontier &= window[:h, :w] >= 15
        for p in self.blacklist:
            i, j = self.grid.cell(*p)
            frontier[max(0, i - lo[0] - 6):i - lo[0] + 7, max(0, j - lo[1] - 6):j - lo[1] + 7] = 0
        for door in self.model.of_kind("door"):
            if door.state == "closed":
                i, j = self.grid.cell(*door.position)
                frontier[max(0, i - lo[0] - 10):i - lo[0] + 11,
                         max(0, j - lo[1] - 10):j - lo[1] + 11] = 0
        if frontier.any():
            cells = np.argwhere(frontier)
            k = int(np.argmin(dist[frontier]))
            c = int(dist[frontier][k])
            if best is None or c < best[0]:
                p = self.grid.point(int(cells[k][0] + lo[0]), int(cells[k][1] + lo[1]))
                best = (c, ("frontier", p))
        if best is None:
            for t in self.model.of_kind("container"):
                if t.state == "closed" and t.id not in self.failed:
                    c = cost(t.position) or 10 ** 6
                    if best is None or c < best[0]:
                        best = (c, ("container", t.id))
        if best is None:
            return None
        if best[1][0] == "door":
            self.opener = best[1][2]
        return best[1]

    # ------------------------------------------------------------------ planning
    def plan(self, env: RemoteEnv, ts: TimeStep) -> TimeStep:
        answers = {q["id"]: a for q in self.queries if (a := self.model.answer(q)) is not None}
        if answers:
            ts = env.answer(answers)
            self.record("note", ts.stage, answered=len(answers))
        text = (self.instruction or {}).get("text", "")
        self.task = parse_instruction(text)
        plan: dict[str, Any] = {"subgoals": list((self.instruction or {}).get("steps", []))}
        item, dest = self.resolve()
        if item is not None and dest is not None:
            rooms = [self.model.last_room, self.model.room_of(item), self.model.room_of(dest)]
            plan["route"] = self.room_route([r for r in rooms if r is not None])
            plan["doors"] = self.route_doors(item, dest)
        self.record("plan", ts.stage, instruction=text, task=self.task, **plan)
        self.nav.reset()
        return env.end_stage({"plan": plan})

    def room_route(self, rooms: list[int]) -> list[int]:
        route = rooms[:1]
        for goal in rooms[1:]:
            prev = {route[-1]: route[-1]}
            queue = [route[-1]]
            while queue and goal not in prev:
                r = queue.pop(0)
                for n in self.model.neighbours(r):
                    if n not in prev:
                        prev[n] = r
                        queue.append(n)
            leg = [goal] if goal in prev else []
            while leg and leg[-1] != route[-1]:
                leg.append(prev[leg[-1]])
            route += leg[::-1][1:]
        return route

    def route_doors(self, item: Thing, dest: Thing) -> list[int]:
        """Doors the grid paths to the item and then to the destination cross, in order."""
        opened = self.nav._open_discs()
        first = self.grid.plan(self.pose[:2], near(item.position, reach_radius(item)),
                               opened=opened) or []
        start = first[-1] if first else item.position
        second = self.grid.plan(start, near(dest.position, reach_radius(dest)),
                                opened=opened) or []
        doors: list[int] = []
        for p in first + second:
            d = self.model.nearest_door(p, 0.5)
            if d is not None and (not doors or doors[-1] != d.id):
                doors.append(d.id)
        return doors

    # ------------------------------------------------------------------ execution
    def resolve(self) -> tuple[Thing | None, Thing | None]:
        """The item to fetch and where it goes (or what it acts on), from the model."""
        t, m = self.task, self.model
        if t is None:
            return None, None
        items = m.find(*t["item"])
        if t["kind"] == "use":
            if not items and ("tool_substitution" in self.reported or self.exhausted):
                # The named tool is gone (or nowhere to be found): another with the same use.
                items = sorted((x for x in m.of_kind("tool") if not x.gone
                                and AFFORDANCES.get(x.category) == t["affordance"]),
                               key=lambda x: math.dist(x.position, self.pose[:2]))
            kind, cat, where = t["target"]
            dests = (m.find(cat, where) if kind == "item" else
                     [x for x in m.find(cat) if m.rooms.get(m.room_of(x)) == where])
        else:
            cat, room_type = t["dest"]
            dests = [x for x in m.find(cat) if x.kind in ("furniture", "container")
                     and m.rooms.get(m.room_of(x)) == room_type]
            if dests and dests[0].state == "unavailable":  # a container of the same room
                room = m.room_of(dests[0])
                dests = sorted((x for x in m.of_kind("container") if m.room_of(x) == room
                                and x.state != "unavailable" and x.id not in self.full),
                               key=lambda x: math.dist(x.position, self.pose[:2]))
        return (items[0] if items else None), (dests[0] if dests else None)

    def execute(self, ts: TimeStep) -> dict[str, Any] | None:
        if self.finished or (ts.steps_left is not None and ts.steps_left <= 1) or self.task is None:
            return None
        item, dest = self.resolve()
        if item is None or (dest is None and self.held == item.id):
            act = self.seek(ts)
            if act is not None or self.exhausted:
                return act
            self.exhausted = True  # looked everywhere: settle for a substitute
            item, dest = self.resolve()
            if item is None:
                return None
        if self.held != item.id:
            return self.fetch(item, ts)
        if dest is None:
            return self.seek(ts)
        return self.deliver(item, dest)

    def act_on(self, thing: Thing, primitive: str, **extra: Any) -> dict[str, Any] | None:
        """Goes within reach of a thing (on the side it was seen from, for an item), then
        acts; shrinks the approach on out_of_reach, widens it when unreachable."""
        radius = self.radius.get(thing.id, reach_radius(thing))
        front = self.front_of(thing)
        sided = front is not None and thing.id not in self.unsided
        goal = (facing(thing.position, radius, front, 0.6 if self.box_of(thing) else 1.2)
                if front is not None and sided else near(thing.position, radius))
        goal = self.in_room(goal, self.model.room_of(thing))
        act = self.nav.go(("reach", thing.id, radius, sided), goal, self.pose, self.collided)
        if isinstance(act, dict):
            return act
        if act == "unreachable":
            if sided:
                self.unsided.add(thing.id)
            else:
                self.radius[thing.id] = radius + 0.3
            return {"primitive": "move", "move": [-0.5, 1.0]}
        self.radius[thing.id] = max(0.5, radius - 0.15)
        return {"primitive": primitive, "target": thing.id, **extra}

    def box_of(self, item: Thing) -> Thing | None:
        """The container an item was seen in, if any."""
        return min((c for c in self.model.of_kind("container")
                    if math.dist(c.position, item.position) < 0.7),
                   key=lambda c: math.dist(c.position, item.position), default=None)

    def in_room(self, goal: Any, room: int | None) -> Any:
        """A goal restricted to cells whose nearest trail point is in ``room`` (the other
        side of a wall is near too, but the thing is not visible from there)."""
        mine = np.array(self.poses.get(room, []) if room is not None else [])
        others = [p for r, trail in self.poses.items() if r != room for p in trail]
        if len(mine) == 0 or not others:
            return goal
        theirs = np.array(others)

        def inside(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
            mask = goal(xs, ys)
            if not mask.any():
                return mask
            px, py = xs[mask], ys[mask]
            d_mine = np.min(np.hypot(px[:, None] - mine[None, :, 0],
                                     py[:, None] - mine[None, :, 1]), axis=1)
            d_other = np.min(np.hypot(px[:, None] - theirs[None, :, 0],
                                      py[:, None] - theirs[None, :, 1]), axis=1)
            mask[mask] = d_mine <= d_other
            return mask

        return inside

    def front_of(self, thing: Thing) -> tuple[float, float] | None:
        """Which side to reach a thing from. An item in a container is seen only from the
        opening: its back is against a wall, so the front faces the room, on the axis toward
        the middle of where the robot has been in that room. Another item: the side it was
        seen from."""
        box = self.box_of(thing) if thing.kind in ("object", "tool") else None
        if box is None:
            return thing.seen_from if thing.kind in ("object", "tool") else None
        room = self.model.room_of(box)
        if room not in self.poses:
            return None
        mx, my = np.mean(self.poses[room], axis=0)
        dx, dy = mx - box.position[0], my - box.position[1]
        if abs(dx) > abs(dy):
            ux, uy = math.copysign(1.0, dx), 0.0
        else:
            ux, uy = 0.0, math.copysign(1.0, dy)
        return box.position[0] + 2 * ux, box.position[1] + 2 * uy

    def fetch(self, item: Thing, ts: TimeStep) -> dict[str, Any] | None:
        box = self.box_of(item)
        if box is not None and box.state == "closed":
            return self.act_on(box, "open")
        close = math.dist(item.position, self.pose[:2]) <= min(1.25, self.radius.get(
            item.id, reach_radius(item)) + 0.05)
        self.unseen = self.unseen + 1 if close and item.id not in self.seen_now else 0
        if self.unseen >= 2 or (self.unseen and box is None):
            self.unseen = 0
            item.gone = True
            kind = "tool_substitution" if item.kind == "tool" else "object_relocation"
            self.report(kind, ts.stage, item=item.id)
            self.search = self.search_targets(backup_first=kind == "object_relocation")
            self.searched = True
            return self.seek(ts)
        return self.act_on(item, "pick")

    def deliver(self, item: Thing, dest: Thing) -> dict[str, Any] | None:
        assert self.task is not None
        if self.task["kind"] == "use":
            return self.act_on(dest, "use", tool=item.id)
        if dest.kind == "container" and dest.state == "closed":
            return self.act_on(dest, "open")
        return self.act_on(dest, "place")

    def search_targets(self, backup_first: bool) -> list[int]:
        """Furniture and containers to look at, the backup area's first, then the nearest."""
        def key(t: Thing) -> tuple[int, float]:
            first = backup_first and self.model.rooms.get(self.model.room_of(t)) == "storage"
            return (0 if first else 1, math.dist(t.position, self.pose[:2]))

        return [t.id for t in sorted(self.model.of_kind("furniture", "container"), key=key)]

    def seek(self, ts: TimeStep) -> dict[str, Any] | None:
        """Looks for what the task needs: at every piece of furniture (opening closed
        containers), then at the map's frontiers and closed doors."""
        if not self.search and not self.searched:
            self.search = self.search_targets(backup_first=True)
            self.searched = True
        while self.search:
            t = self.model.things[self.search[0]]
            if t.kind == "container" and t.state == "closed" and t.id not in self.failed:
                act = self.act_on(t, "open")
                if act is not None:
                    return act
            goal = self.in_room(near(t.position, 1.4), self.model.room_of(t))
            act = self.nav.go(("seek", t.id), goal, self.pose, self.collided)
            if isinstance(act, dict):
                return act
            self.search.pop(0)
        goal = self.next_goal()
        if goal is None:
            return None
        self.goal = goal
        return self.pursue()

    # ------------------------------------------------------------------ the loop
    def run(self, env: RemoteEnv) -> None:
        env.hello(agent="eagc-track1-heuristic/1")
        ts = env.reset()
        self.record("stage", ts.stage)
        while not ts.episode_over:
            self.perceive(ts)
            if ts.stage == "planning":
                ts = self.plan(env, ts)
                self.record("stage", ts.stage)
                continue
            act = self.explore(ts) if ts.stage == "exploration" else self.execute(ts)
            if act is None:
                self.model.write(OUT)
                if ts.stage == "exploration":
                    self.record("model_update", ts.stage, reason="exploration done")
                    ts = env.end_stage()
                    self.record("stage", ts.stage)
                    continue
                act = {"primitive": "done"}
            self.step += 1
            self.last = act
            ts = env.step(act)
            if act["primitive"] in ("place", "use") and ts.action is not None and ts.action.ok:
                self.finished = True
        self.perceive(ts)
        self.model.write(OUT)
        self.record("note", ts.stage, end=ts.end_reason)


def main() -> int:
    with RemoteEnv() as env:
        Agent().run(env)
    return 0


if __name__ == "__main__":
    sys.exit(main())
