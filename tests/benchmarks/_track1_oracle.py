"""A privileged Track 1 oracle and a do-nothing agent, for calibration (never a baseline).

``Oracle`` reads the live episode's ground truth (in process): it writes the true house as
its world model and ends exploration at once, answers every query from the truth, submits
the shortest route as its plan, then does the goals one after the other on a free-space
grid of the true house (walls, furniture, door panels), opening closed doors and
containers on its way. It logs the exception the step it happens, rewrites its model, and
takes the valid alternative (a detour, the new place, a substitute). Its score shows that
the tasks are solvable within the step budgets.

On a split that acts by pixel (``vision``) it acts and writes through the same channels as
any agent there: it faces what it acts on (sweeping a little when it is not in frame) and
names the pixel of the last frame nearest the centre of its mask (from an item it first
edges back in small steps: ``ITEM_SEARCH``); its files, plan and answers use ids of its own
(the true ids under a fixed permutation), which the score matches back by position
(``plugins.track1._matching``).

``DoNothing`` ends each stage at once and sends ``done``.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np

from plugins.track1 import Goal, Track1Episode
from plugins.track1._queries import truth_of
from schemas import (
    Affordance,
    Connection,
    ContainerState,
    DoorState,
    ObjectEntry,
    Room,
    WorldModel,
)
from simhost.client import OutputFiles, TimeStep
from simhost.worlds.track1 import Door, Furniture, HouseTruth

RES = 0.05
ROBOT = 0.25 + 0.04  # the base's radius (simhost.worlds.track1's ROBOT_RADIUS) plus a margin
TURN = math.pi / 4
STEP = 0.5
ASIDE = ((0.0, 0.2, 0.0), (0.0, -0.2, 0.0), (0.0, 0.35, 0.0), (0.0, -0.35, 0.0))
SEARCH = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.3), (0.0, 0.0, -0.3), *ASIDE)
"""By pixel: (step back, m; step aside, m; turn, rad) from the access pose, tried in turn
while the target is not in frame or the host refuses its pixel (``REFUSED``; refused as
``not_visible``, the search goes on at once with ``ASIDE``: no turn on the spot changes the
line of sight, which the host draws from the robot's centre); poses in an obstacle's margin
are passed over."""
EDGE = 0.02
ITEM_SEARCH = ((0.0, 0.0, 0.0), *((EDGE * k, 0.0, 0.0) for k in range(1, 9)),
               (0.0, 0.0, 0.3), (0.0, 0.0, -0.3), (0.3, 0.0, 0.0), (0.5, 0.0, 0.0),
               (0.5, 0.0, 0.3), (0.5, 0.0, -0.3), (0.3, 0.0, 0.3), (0.3, 0.0, -0.3), *ASIDE)
"""By pixel, for an item: first edging straight back from the access pose in ``EDGE``
steps (0.16 m in all), then turns and farther stand-offs (a low item in an open drawer
shows only from farther), then ``ASIDE``. The camera looks down at 25 degrees with a
75-degree field, so the frame's lower edge is 62.5 degrees below the eye: an item at the
bottom of a deep open container (a bin, 0.5 m) shows over its rim only from a band of
stand-offs a few centimetres wide just behind the access pose."""
REFUSED = frozenset({"not_visible", "out_of_reach", "nothing_there"})
"""Refusals of an action by pixel that send the search on: the host's view rule is line of
sight from the robot's centre to fixed points of the thing, so a thing in frame may still be
out of view (say an open fridge door across the line, nearer than the camera draws)."""


def world_model(truth: HouseTruth, step: int,
                rename: Callable[[int], int] = lambda i: i) -> WorldModel:
    """The true house as a ``world_model.json``; ``rename``: the ids it writes (room ids
    stay)."""
    return WorldModel(
        step=step,
        rooms=[Room(id=r.id, type=r.type) for r in truth.rooms],
        connections=[Connection(rooms=c.rooms, door=rename(c.door)) for c in truth.connections],
        doors=[DoorState(id=rename(d.id), state=d.state) for d in truth.doors],  # type: ignore[arg-type]
        containers=[ContainerState(id=rename(c.id), type=c.category, room=c.room,  # type: ignore[arg-type]
                                   state=c.state) for c in truth.containers],
        objects=[ObjectEntry(id=rename(o.id), category=o.category, colour=o.colour,
                             room=o.room, receptacle=rename(o.receptacle),
                             position=o.position[:2], state=o.state)
                 for o in truth.objects],
        affordances=[Affordance(tool=rename(a.tool), affordance=a.affordance)
                     for a in truth.affordances],
    )


def permutation(truth: HouseTruth, seed: int = 0) -> dict[int, int]:
    """A fixed permutation of every instance id of the house onto ids of its own (from
    1000), so that no written id is a true one."""
    ids = sorted({d.id for d in truth.doors} | {f.id for f in (*truth.furniture,
                                                                *truth.containers)}
                 | {o.id for o in truth.objects} | {t.id for t in truth.tools})
    order = np.random.default_rng(seed).permutation(len(ids))
    return {i: 1000 + int(k) for i, k in zip(ids, order, strict=True)}


def pixel_of(segmentation: np.ndarray | None, instance: int) -> list[int] | None:
    """The pixel ``[u, v]`` of ``instance``'s mask nearest the mask's centre; None when
    it is not in the frame."""
    if segmentation is None:
        return None
    vs, us = np.nonzero(segmentation == instance)
    if len(us) == 0:
        return None
    k = int(np.argmin((us - us.mean()) ** 2 + (vs - vs.mean()) ** 2))
    return [int(us[k]), int(vs[k])]


class DoNothing:
    """Ends every stage at once and sends done."""

    def __init__(self, episode: Track1Episode | None = None) -> None:
        pass

    def run(self, env: Any) -> None:
        env.hello(agent="do-nothing")
        ts = env.reset()
        while not ts.episode_over:
            ts = env.step({"primitive": "done"}) if ts.stage == "execution" else env.end_stage()


class _Grid:
    """Free space of the true house for the robot's centre, and distance fields."""

    def __init__(self, ep: Track1Episode, doors: dict[int, str]) -> None:
        layout = ep.env.layout
        w, h = layout.extent
        self.nx, self.ny = int(math.ceil(w / RES)) + 1, int(math.ceil(h / RES)) + 1
        xs = (np.arange(self.nx) + 0.5) * RES
        ys = (np.arange(self.ny) + 0.5) * RES
        self.gx, self.gy = np.meshgrid(xs, ys, indexing="ij")
        blocked = np.zeros((self.nx, self.ny), bool)
        for wall in layout.walls:
            (cx, cy), (hx, hy) = wall.centre, wall.half
            blocked |= self._box(cx - hx, cy - hy, cx + hx, cy + hy)
        for f in layout.furniture:
            blocked |= self._box(*f.footprint)
        self.doorway: dict[int, np.ndarray] = {}
        for d in layout.doors:
            hx, hy = d.hinge
            if doors[d.id] == "open":
                nx, ny = d.swing_normal
                blocked |= self._segment((hx, hy), (hx + nx * d.width, hy + ny * d.width))
            else:
                c, s = math.cos(d.yaw), math.sin(d.yaw)
                seg = self._segment((hx, hy), (hx + c * d.width, hy + s * d.width))
                blocked |= seg
                if doors[d.id] == "closed":
                    self.doorway[d.id] = seg
        self.blocked = blocked

    def _box(self, x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
        dx = np.maximum(np.maximum(x0 - self.gx, self.gx - x1), 0.0)
        dy = np.maximum(np.maximum(y0 - self.gy, self.gy - y1), 0.0)
        return np.hypot(dx, dy) < ROBOT

    def _segment(self, a: tuple[float, float], b: tuple[float, float]) -> np.ndarray:
        ax, ay = a
        vx, vy = b[0] - ax, b[1] - ay
        t = np.clip(((self.gx - ax) * vx + (self.gy - ay) * vy) / (vx * vx + vy * vy), 0, 1)
        return np.hypot(self.gx - (ax + t * vx), self.gy - (ay + t * vy)) < ROBOT + 0.03

    def cell(self, x: float, y: float) -> tuple[int, int]:
        return (min(max(int(x / RES), 0), self.nx - 1), min(max(int(y / RES), 0), self.ny - 1))

    def field(self, goal: tuple[float, float], through: frozenset[int]) -> np.ndarray:
        """Steps (8-connected) from every cell to the goal; doorways of ``through`` (closed
        doors) count as free; -1 where unreachable."""
        free = ~self.blocked
        for door in through:
            if door in self.doorway:
                free |= self.doorway[door]
        gi, gj = self.cell(*goal)
        free[gi, gj] = True
        dist = np.full(free.shape, -1, np.int32)
        dist[gi, gj] = 0
        queue = deque([(gi, gj)])
        while queue:
            i, j = queue.popleft()
            d = dist[i, j] + 1
            for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)):
                a, b = i + di, j + dj
                if 0 <= a < self.nx and 0 <= b < self.ny and free[a, b] and dist[a, b] < 0:
                    dist[a, b] = d
                    queue.append((a, b))
        return dist

    def line_free(self, a: tuple[float, float], b: tuple[float, float], dist: np.ndarray
                  ) -> bool:
        n = max(2, int(math.dist(a, b) / (RES / 2)))
        for t in np.linspace(0.0, 1.0, n):
            if dist[self.cell(a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t)] < 0:
                return False
        return True


class Oracle:
    """Plays an episode from the ground truth (privileged; see the module)."""

    def __init__(self, episode: Track1Episode) -> None:
        self.ep = episode
        self.files = OutputFiles()
        self.step = 0
        self.reported = False
        self._grids: dict[tuple[tuple[int, str], ...], _Grid] = {}
        self._fields: dict[Any, np.ndarray] = {}
        self.opened: set[int] = set()
        self.by_pixel = episode.env.config.actions_by == "pixel"
        self.ids: dict[int, int] = {}
        self.sweep = 0  # vision: how far the search for the target in frame has gone
        self.refused = ""  # vision: why the last action by pixel was refused (REFUSED)
        self._aimed: tuple[tuple[float, float], tuple[float, float]] | None = None

    def own(self, instance: int) -> int:
        """The id the oracle writes for a true id (itself where the split shows ids)."""
        return self.ids.get(instance, instance)

    def model(self, step: int) -> WorldModel:
        return world_model(self.truth(), step, self.own)

    # ------------------------------------------------------------------ knowledge
    def truth(self) -> HouseTruth:
        return self.ep.env.ground_truth()

    def grid(self) -> _Grid:
        doors = self.ep.house.world.doors
        key = tuple(sorted(doors.items()))
        if key not in self._grids:
            self._grids[key] = _Grid(self.ep, dict(doors))
        return self._grids[key]

    # ------------------------------------------------------------------ the stages
    def run(self, env: Any) -> None:
        env.hello(agent="oracle")
        ts = env.reset()
        self.files.log(step=0, stage=ts.stage, event="stage")
        if self.by_pixel:
            self.ids = permutation(self.truth())
        self.files.write(self.model(0))
        ts = env.end_stage()
        truth = self.truth()
        answers = {q.id: truth_of(q, truth) for q in self.ep.spec.queries}
        answers = {k: [self.own(i) for i in v] if q.kind == "tools_for" else v
                   for q in self.ep.spec.queries for k, v in [(q.id, answers[q.id])]}
        ts = env.answer(answers)
        plan = self.plan(truth)
        plan["doors"] = [self.own(d) for d in plan["doors"]]
        ts = env.end_stage({"plan": plan})
        while not ts.episode_over:
            action = self.next_action(ts) if self.ep.success() is False else None
            if action is not None and self.by_pixel:
                action = self.through_pixels(action)
            ts = env.step(action or {"primitive": "done"})
            self.step += 1
            if action is not None and "target_px" in action and ts.action is not None:
                self.refused = ts.action.reason if ts.action.reason in REFUSED else ""
                if ts.action.ok:
                    self.sweep = 0
            rec = self.ep.exception.record
            if rec is not None and not self.reported:
                self.reported = True
                self.files.log(step=self.step, stage=ts.stage, event="exception_detected",
                               exception_type=rec.type)
                self.files.write(self.model(self.step))
        self.files.write(self.model(self.step))

    def plan(self, truth: HouseTruth) -> dict[str, Any]:
        house = self.ep.house
        rooms = [house.robot_room]
        for g in self.ep.task.goals:
            for entity in (g.fetched, g.destination):
                obj, rec = truth.object(entity), truth.receptacle(entity)
                rooms.append(obj.room if obj is not None else rec.room)  # type: ignore[union-attr]
        route = [rooms[0]]
        for a, b in zip(rooms, rooms[1:], strict=False):
            route += house.shortest_path(a, b)[1:]
        return {"subgoals": list(self.ep.task.steps), "route": route,
                "doors": house.route_doors(route)}

    # ------------------------------------------------------------------ by pixel
    def aim(self, at: tuple[float, float], entity: int, yaw: float
            ) -> tuple[tuple[float, float], float]:
        """Where to act from and facing which way: ``at`` and ``yaw`` where the split takes
        ids; by pixel, toward the thing (its mask then lies in frame), from the pose of the
        search (``ITEM_SEARCH``, ``SEARCH``) it has come to."""
        if not self.by_pixel:
            return at, yaw
        truth = self.truth()
        obj, rec = truth.object(entity), truth.receptacle(entity)
        door = next((d for d in truth.doors if d.id == entity), None)
        where = obj.position[:2] if obj is not None else rec.position if rec is not None \
            else door.position if door is not None else None
        if where is None:
            return at, yaw
        self._aimed = (at, where)
        search = self._search(entity)
        return self._pose(at, where, search[self.sweep % len(search)])

    def _search(self, entity: int) -> tuple[tuple[float, float, float], ...]:
        return ITEM_SEARCH if self.truth().object(entity) is not None else SEARCH

    @staticmethod
    def _pose(at: tuple[float, float], where: tuple[float, float],
              entry: tuple[float, float, float]) -> tuple[tuple[float, float], float]:
        """A search entry's pose: back from ``at`` away from ``where``, aside to its left
        (negative: right), facing ``where`` turned by the entry's turn."""
        back, aside, turn = entry
        d = max(1e-6, math.dist(at, where))
        ux, uy = (where[0] - at[0]) / d, (where[1] - at[1]) / d
        x, y = at[0] - back * ux - aside * uy, at[1] - back * uy + aside * ux
        return (x, y), math.atan2(where[1] - y, where[0] - x) + turn

    def _free(self, entry: tuple[float, float, float]) -> bool:
        """Whether the robot fits at an entry's pose (the access pose always counts)."""
        if self._aimed is None or entry[:2] == (0.0, 0.0):
            return True
        (x, y), _ = self._pose(*self._aimed, entry)
        grid = self.grid()
        return bool(not grid.blocked[grid.cell(x, y)])

    def through_pixels(self, action: dict[str, Any]) -> dict[str, Any]:
        """An id-addressed action as the pixel split takes it: the target's pixel (the tool
        is the held item); when it is not in frame, or its pixel was just refused as out of
        view, the next pose of the search that the robot fits in: a step straight back of a
        few centimetres is made here, exactly (the drive stops within 0.06 m of its goal),
        any other pose is driven to from the next call on (the search starts over when an
        action by pixel succeeds)."""
        if "target" not in action:
            return action
        target = int(action["target"])
        px = pixel_of(self.ep.env.last_segmentation(), target)
        if px is not None and not self.refused:
            return {"primitive": action["primitive"], "target_px": px}
        search = self._search(target)
        before = search[self.sweep % len(search)]
        aside = len(search) - len(ASIDE)
        if self.refused == "not_visible" and self.sweep % len(search) < aside:
            self.sweep += aside - self.sweep % len(search) - 1
        self.refused = ""
        self.sweep += 1
        while self.sweep % len(search) and not self._free(search[self.sweep % len(search)]):
            self.sweep += 1
        (back0, aside0, turn0), (back1, aside1, turn1) = before, search[self.sweep % len(search)]
        if aside0 == aside1 == turn0 == turn1 == 0.0 and 0.0 < back1 - back0 <= 2 * EDGE:
            return {"primitive": "move",
                    "move": [-(back1 - back0) / self.ep.env.config.max_forward, 0.0]}
        return {"primitive": "noop"}

    # ------------------------------------------------------------------ execution
    def next_action(self, ts: TimeStep) -> dict[str, Any] | None:
        ep, truth = self.ep, self.truth()
        world = ep.house.world
        for goal in ep.task.goals:
            if ep.goal_done(goal):
                continue
            fetched = self._fetched(goal, truth)
            if world.held >= 0 and world.held != fetched:
                return self.put_down(truth)
            if world.held != fetched:
                obj = truth.object(fetched)
                assert obj is not None
                rec = truth.receptacle(obj.receptacle)
                assert rec is not None
                if rec.kind == "container" and world.containers[rec.id] != "open":
                    return self.act_at(rec.id, "open")
                return self.act_at(rec.id, "pick", target=fetched)
            dests = ep.accepted_destinations(goal)
            if goal.kind == "place":  # a substitute with room (a full one refuses the place)
                dests = [d for d in dests if world.free_slot(ep.env.layout, d) is not None] \
                    or dests
            x, y, _ = ep.house.robot_pose
            dest = min(dests, key=lambda d: math.dist(self._place_of(truth, d).access[:2],
                                                      (x, y)))
            if goal.kind == "use":
                return self.act_at(self._place_of(truth, dest).id, "use", target=dest,
                                   tool=fetched)
            if goal.container and world.containers[dest] != "open":
                return self.act_at(dest, "open")
            return self.act_at(dest, "place")
        return None

    def put_down(self, truth: HouseTruth) -> dict[str, Any]:
        """Puts the held item (not needed now) on the nearest surface with room."""
        x, y, _ = self.ep.house.robot_pose
        world = self.ep.house.world
        free = [f for f in truth.furniture if world.free_slot(self.ep.env.layout, f.id) is not None]
        f = min(free, key=lambda f: math.dist(f.access[:2], (x, y)))
        return self.act_at(f.id, "place")

    def _fetched(self, goal: Goal, truth: HouseTruth) -> int:
        if goal.kind == "place":
            return goal.fetched
        tools = self.ep.accepted_tools(goal)
        x, y, _ = self.ep.house.robot_pose
        held = self.ep.house.world.held
        if held in tools:
            return held
        return min(tools, key=lambda t: math.dist(truth.object(t).position[:2], (x, y)))  # type: ignore[union-attr]

    @staticmethod
    def _place_of(truth: HouseTruth, entity: int) -> Any:
        rec = truth.receptacle(entity)
        if rec is None:
            obj = truth.object(entity)
            assert obj is not None
            rec = truth.receptacle(obj.receptacle)
        return rec

    def act_at(self, place: int, primitive: str, **fields: Any) -> dict[str, Any]:
        """Goes to a furniture's access pose, faces it, and acts."""
        f = self.ep.env.layout.entity(place)
        assert isinstance(f, Furniture)
        ax, ay, ayaw = f.access
        move = self.go(*self.aim((ax, ay), fields.get("target", place), ayaw))
        if move is not None:
            return move
        return {"primitive": primitive, "target": fields.get("target", place),
                **({"tool": fields["tool"]} if "tool" in fields else {})}

    def go(self, goal: tuple[float, float], yaw: float) -> dict[str, Any] | None:
        """The next move toward a pose (opening closed doors on the way), or None there.

        By pixel, within 0.6 m of the pose (the search's step back or aside) it drives
        straight there, forward or backward (``_escape``): a pose of the search may lie in
        an obstacle's margin, where the grid has no route. Not where the grid has a route
        from here and the straight line leaves free space: that line may graze an obstacle
        (an open door's edge), and a robot wedged there drives into it for ever."""
        x, y, th = self.ep.house.robot_pose
        if math.dist((x, y), goal) > 0.06:
            found = self._closed_door_on_path(goal)
            if found is not None:
                return self._open_door(*found)
            if self.by_pixel and math.dist((x, y), goal) < 0.6 and self._straight(goal):
                return self._escape(goal)
            return self._drive(goal, frozenset())
        err = math.remainder(yaw - th, math.tau)
        if abs(err) > 0.05:
            return {"primitive": "move", "move": [0.0, max(-1.0, min(1.0, err / TURN))]}
        return None

    def _straight(self, goal: tuple[float, float]) -> bool:
        """Whether the grid has no route from the robot to ``goal``, or the straight line
        there stays in free space."""
        grid, dist = self.grid(), self._field(goal, frozenset())
        x, y, _ = self.ep.house.robot_pose
        return bool(dist[grid.cell(x, y)] < 0) or grid.line_free((x, y), goal, dist)

    def _field(self, goal: tuple[float, float], through: frozenset[int]) -> np.ndarray:
        grid = self.grid()
        key = (id(grid), goal, through)
        if key not in self._fields:
            self._fields[key] = grid.field(goal, through)
        return self._fields[key]

    def _path(self, goal: tuple[float, float], through: frozenset[int]
              ) -> list[tuple[float, float]]:
        grid, dist = self.grid(), self._field(goal, through)
        x, y, _ = self.ep.house.robot_pose
        i, j = grid.cell(x, y)
        if dist[i, j] < 0:  # the robot's cell counts as free
            around = [(i + a, j + b) for a in (-1, 0, 1) for b in (-1, 0, 1)
                      if 0 <= i + a < grid.nx and 0 <= j + b < grid.ny and dist[i + a, j + b] >= 0]
            if not around:
                return []
            i, j = min(around, key=lambda c: dist[c])
        path = [(i, j)]
        while dist[path[-1]] > 0 and len(path) < 2000:
            a, b = path[-1]
            nxt = min(((a + da, b + db) for da in (-1, 0, 1) for db in (-1, 0, 1)
                       if (da or db) and 0 <= a + da < grid.nx and 0 <= b + db < grid.ny
                       and dist[a + da, b + db] >= 0), key=lambda c: dist[c])
            path.append(nxt)
        return [((a + 0.5) * RES, (b + 0.5) * RES) for a, b in path] + [goal]

    def _closed_door_on_path(self, goal: tuple[float, float]) -> tuple[Door, int] | None:
        """The first closed door the way to ``goal`` must pass, and the room before it."""
        grid = self.grid()
        closed = frozenset(grid.doorway)
        if not closed:
            return None
        direct = self._field(goal, frozenset())
        x, y, _ = self.ep.house.robot_pose
        if direct[grid.cell(x, y)] >= 0:
            return None
        layout = self.ep.env.layout
        before = (x, y)
        for px, py in self._path(goal, closed):
            cell = grid.cell(px, py)
            for door_id, seg in grid.doorway.items():
                if seg[cell]:
                    door = layout.entity(door_id)
                    assert isinstance(door, Door)
                    room = layout.room_at(*before)
                    return door, room if room in door.rooms else door.rooms[0]
            before = (px, py)
        return None

    def _open_door(self, door: Door, side: int) -> dict[str, Any]:
        ax, ay, ayaw = door.approach(side, 1.4 if side == door.swing_room else 0.8)
        move = self._drive_to(*self.aim((ax, ay), door.id, ayaw))
        return move or {"primitive": "open", "target": door.id}

    def _drive_to(self, goal: tuple[float, float], yaw: float) -> dict[str, Any] | None:
        x, y, th = self.ep.house.robot_pose
        if math.dist((x, y), goal) > 0.06:
            return self._drive(goal, frozenset())
        err = math.remainder(yaw - th, math.tau)
        if abs(err) > 0.05:
            return {"primitive": "move", "move": [0.0, max(-1.0, min(1.0, err / TURN))]}
        return None

    def _drive(self, goal: tuple[float, float], through: frozenset[int]) -> dict[str, Any]:
        """A move toward the farthest point of the path in straight, free sight."""
        path = self._path(goal, through)
        x, y, th = self.ep.house.robot_pose
        dist = self._field(goal, through)
        grid = self.grid()
        ci, cj = grid.cell(x, y)
        if dist[ci, cj] < 0:
            window = dist[max(0, ci - 8):ci + 9, max(0, cj - 8):cj + 9]
            cells = np.argwhere(window >= 0)
            if len(cells):
                k = int(np.argmin(((cells - [min(ci, 8), min(cj, 8)]) ** 2).sum(axis=1)))
                i, j = cells[k] + [max(0, ci - 8), max(0, cj - 8)]
                return self._escape(((i + 0.5) * RES, (j + 0.5) * RES))
        target = path[1] if len(path) > 1 else goal
        for p in path[1:80]:
            if grid.line_free((x, y), p, dist):
                target = p
        dx, dy = target[0] - x, target[1] - y
        err = math.remainder(math.atan2(dy, dx) - th, math.tau)
        if abs(err) > TURN:
            return {"primitive": "move", "move": [0.0, math.copysign(1.0, err)]}
        return {"primitive": "move",
                "move": [min(1.0, math.hypot(dx, dy) / STEP), err / TURN]}

    def _escape(self, clear: tuple[float, float]) -> dict[str, Any]:
        """Out of an obstacle's margin: straight to the nearest clear cell, forward or
        backward, whichever needs the smaller turn."""
        x, y, th = self.ep.house.robot_pose
        dx, dy = clear[0] - x, clear[1] - y
        ahead = math.remainder(math.atan2(dy, dx) - th, math.tau)
        back = math.remainder(ahead + math.pi, math.tau)
        err, sign = (ahead, 1.0) if abs(ahead) <= abs(back) else (back, -1.0)
        if abs(err) > TURN:
            return {"primitive": "move", "move": [0.0, math.copysign(1.0, err)]}
        return {"primitive": "move",
                "move": [sign * min(1.0, (math.hypot(dx, dy) + 0.05) / STEP), err / TURN]}
