"""The heuristic map planner (paper Table IV): what a team can start from.

- Exploration: an occupancy grid from the range scan (with the odometry pose); goes to the
  nearest frontier, opens closed doors with unexplored space behind them and closed
  containers (to see inside); keeps rooms (read from the sign at each doorway), door
  connectivity, door/container states and objects in a world model (the map, the model,
  navigation and exploration are ``simhost.client.skills.Explorer``, which this planner extends),
  written
  to ``/output/world_model.json`` before the stage ends (or its step budget runs out).
- Planning: reads the instruction into goals (``simhost.client.skills.parse``: rule-based
  decomposition of the track's grammar), answers the queries it can from the model, and
  submits a plan: the instruction's steps, the room route and the doors its breadth-first
  grid paths cross.
- Execution: goal after goal, fetches the item (putting down what it holds first), then
  places it or uses it on the target, facing what it acts on, re-planning as the map
  changes. Exceptions show through their effects: ``open`` fails with ``locked``,
  ``open``/``place`` fail with ``unavailable``, an item is missing where the model put it.
  Each is logged (``exception_detected``), the model is updated and written, and the plan
  adapts: a detour, a search (the storage room first), another container in the same room,
  another tool with the same use.

Uses only ``simhost.client`` (``RemoteEnv``, ``OutputFiles``), ``simhost.client.skills``, numpy
and the standard library.
"""

from __future__ import annotations

import math
from typing import Any

from simhost.client import OutputFiles, RemoteEnv, TimeStep
from simhost.client.skills import AFFORDANCES, Explorer, Thing, face, near, parse, reach_radius


class MapPlanner(Explorer):
    """Explores by frontiers, keeps a map and a model, plans shortest paths (see above)."""

    name = "eagc-track1-heuristic/2"

    def __init__(self) -> None:
        super().__init__()
        self.files = OutputFiles()
        self.carried: set[int] = set()
        self.full: set[int] = set()
        self.exhausted = False
        self.unseen = 0
        self.last: dict[str, Any] | None = None
        self.instruction: dict[str, Any] | None = None
        self.goals: list[dict[str, Any]] = []
        self.done_goals = 0
        self.queries: list[dict[str, Any]] = []
        self.reported: set[str] = set()
        self.search: list[int] = []
        self.searched = False

    # ------------------------------------------------------------------ records
    def record(self, event: str, stage: str, exception_type: str | None = None,
               **data: Any) -> None:
        self.files.log(step=self.step, stage=stage, event=event, exception_type=exception_type,
                       data=data)

    def report(self, kind: str, stage: str, **data: Any) -> None:
        """An exception noticed: log it, update the model file, say how the plan changes."""
        if kind in self.reported or stage != "execution":
            return
        self.reported.add(kind)
        self.record("exception_detected", stage, exception_type=kind, **data)
        self.model.write(self.files)
        self.record("model_update", stage, reason=kind)
        self.record("replan", stage, reason=kind)
        self.nav.reset()

    # ------------------------------------------------------------------ perception
    def perceive(self, ts: TimeStep) -> None:
        for t in self.sense(ts.observation):  # the map and the model (simhost.client.skills)
            if t.kind == "door":
                if t.state == "locked":  # where exceptions show themselves (dev split)
                    self.report("door_lock", ts.stage, door=t.id)
            elif t.kind == "container" and t.state == "unavailable":
                self.report("container_unavailable", ts.stage, container=t.id)
        for t in self.model.moved:  # the agent moves only what it carries
            if t.id not in self.carried:
                self.report("object_relocation", ts.stage, item=t.id)
        if self.held >= 0:
            self.carried.add(self.held)
        self.failure(ts, ts.observation["action_result"])
        for message in ts.messages:
            if message.type == "instruction" and "text" in message.data:
                self.instruction = dict(message.data)
            elif message.type == "queries":
                self.queries = list(message.data.get("queries", []))

    def failure(self, ts: TimeStep, result: dict[str, Any]) -> None:
        """What a failed action says about the world (the only sign of some exceptions)."""
        last = self.last
        if last is None or result.get("ok", True):
            return
        reason, target = result.get("reason", ""), last.get("target")
        thing = self.model.things.get(target) if target is not None else None
        if last["primitive"] == "place" and reason in ("receptacle_full", "unavailable"):
            self.full.add(target)
        if reason == "locked" and thing is not None:
            thing.state = "locked"
            self.report("door_lock", ts.stage, door=target)
        if reason == "unavailable" and thing is not None and thing.kind == "container":
            thing.state = "unavailable"
            self.report("container_unavailable", ts.stage, container=target)
        if last["primitive"] == "open":  # to the opener that sent it (an exploration
            for opener in (self.opener, self.nav.door):  # goal's may be a stale one)
                if opener is not None and opener.door.id == target:
                    opener.result(reason)
                    break

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

    # ------------------------------------------------------------------ planning
    def plan(self, env: RemoteEnv, ts: TimeStep) -> TimeStep:
        answers = {q["id"]: a for q in self.queries if (a := self.model.answer(q)) is not None}
        if answers:
            ts = env.answer(answers)
            self.record("note", ts.stage, answered=len(answers))
        text = (self.instruction or {}).get("text", "")
        self.goals = parse(text)
        plan: dict[str, Any] = {"subgoals": list((self.instruction or {}).get("steps", []))}
        if self.goals:
            item, dest = self.resolve(self.goals[0])
            if item is not None and dest is not None:
                rooms = [self.room, self.model.room_of(item), self.model.room_of(dest)]
                plan["route"] = self.room_route([r for r in rooms if r is not None and r >= 0])
                plan["doors"] = self.route_doors(item, dest)
        self.record("plan", ts.stage, instruction=text, goals=self.goals, **plan)
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
    def resolve(self, goal: dict[str, Any]) -> tuple[Thing | None, Thing | None]:
        """The item to fetch and where it goes (or what it acts on), from the model."""
        m = self.model
        ref = goal["item"] if goal["kind"] == "place" else goal["tool"]
        items = m.matches(ref)
        if not items and ref.get("room"):
            items = m.find(ref["category"], ref.get("colour"))
        if goal["kind"] == "use" and not items and (
                "tool_substitution" in self.reported or self.exhausted):
            # The named tool is gone (or nowhere to be found): another with the same use.
            items = [x for x in m.of_kind("tool") if not x.gone
                     and AFFORDANCES.get(x.category) == goal["affordance"]]
        items.sort(key=lambda x: math.dist(x.position, self.pose[:2]))
        if self.held >= 0 and any(x.id == self.held for x in items):
            items = [m.things[self.held]]
        if goal["kind"] == "use":
            dests = m.matches(goal["target"])
        else:
            dests = [x for x in m.matches(goal["dest"]) if x.kind in ("furniture", "container")]
            if dests and dests[0].state == "unavailable":  # a container of the same room
                room = m.room_of(dests[0])
                dests = sorted((x for x in m.of_kind("container") if m.room_of(x) == room
                                and x.state != "unavailable" and x.id not in self.full),
                               key=lambda x: math.dist(x.position, self.pose[:2]))
        return (items[0] if items else None), (dests[0] if dests else None)

    def execute(self, ts: TimeStep) -> dict[str, Any] | None:
        if (ts.steps_left is not None and ts.steps_left <= 1) or self.done_goals >= len(
                self.goals):
            return None
        goal = self.goals[self.done_goals]
        item, dest = self.resolve(goal)
        if self.held >= 0 and (item is None or self.held != item.id):
            return self.put_down()
        if item is None or (dest is None and self.held == item.id):
            act = self.seek(ts)
            if act is not None or self.exhausted:
                return act
            self.exhausted = True  # looked everywhere: settle for a substitute
            item, dest = self.resolve(goal)
            if item is None:
                return None
        if self.held != item.id:
            return self.fetch(item, ts)
        if dest is None:
            return self.seek(ts)
        return self.deliver(goal, item, dest)

    def put_down(self) -> dict[str, Any] | None:
        """Puts what it holds (not needed now) on the nearest surface that has room."""
        spots = sorted((t for t in self.model.of_kind("furniture") if t.id not in self.full),
                       key=lambda t: math.dist(t.position, self.pose[:2]))
        return self.act_on(spots[0], "place") if spots else None

    def fetch(self, item: Thing, ts: TimeStep) -> dict[str, Any] | None:
        box = self.box_of(item)
        if box is not None and box.state == "closed":
            return self.act_on(box, "open")
        close = math.dist(item.position, self.pose[:2]) <= min(1.25, self.radius.get(
            item.id, reach_radius(item)) + 0.05)
        self.unseen = self.unseen + 1 if close and item.id not in self.seen_now else 0
        if self.unseen >= 3 or (self.unseen >= 2 and box is None):
            self.unseen = 0
            item.gone = True
            kind = "tool_substitution" if item.kind == "tool" else "object_relocation"
            self.report(kind, ts.stage, item=item.id)
            self.search = self.search_targets(backup_first=kind == "object_relocation")
            self.searched = True
            return self.seek(ts)
        return self.act_on(item, "pick")

    def deliver(self, goal: dict[str, Any], item: Thing, dest: Thing) -> dict[str, Any] | None:
        if goal["kind"] == "use":
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
            turn = face(self.pose, t.position)
            if turn is not None and self.turns < 4:
                self.turns += 1
                return turn
            self.turns = 0
            self.search.pop(0)
        goal = self.next_goal()
        if goal is None:
            return None
        self.goal = goal
        return self.pursue()

    # ------------------------------------------------------------------ the loop
    def run(self, env: RemoteEnv) -> None:
        env.hello(agent=self.name)
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
                self.model.write(self.files)
                if ts.stage == "exploration":
                    self.record("model_update", ts.stage, reason="exploration done")
                    ts = env.end_stage()
                    self.record("stage", ts.stage)
                    continue
                act = {"primitive": "done"}
            if ts.stage == "exploration" and ts.steps_left is not None and ts.steps_left <= 3:
                self.model.write(self.files)  # the stage may end with this step
            self.step += 1
            self.last = act
            ts = env.step(act)
            if (ts.stage == "execution" and act["primitive"] in ("place", "use")
                    and ts.action is not None and ts.action.ok
                    and self.done_goals < len(self.goals)):
                goal = self.goals[self.done_goals]
                _item, dest = self.resolve(goal)
                if (goal["kind"] == "use") == (act["primitive"] == "use") and (
                        dest is not None and act["target"] == dest.id):
                    self.done_goals += 1
                    self.search, self.searched, self.exhausted = [], False, False
        self.perceive(ts)
        self.model.write(self.files)
        self.record("note", ts.stage, end=ts.end_reason)

