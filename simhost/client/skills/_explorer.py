"""What an agent keeps from its own observations, and how it moves on it, one step at a time.

``Explorer`` holds the occupancy grid (``_mapping.Grid``), the world model
(``_model.WorldModel``), the navigator (``_navigation.Navigator``), the robot's pose, room
and hand, and where it has been in each room. ``sense`` adds one observation; ``act_on``
returns the next action that brings the robot within reach of a thing, facing it, and then
acts on it; ``next_goal`` and ``pursue`` pick and follow the nearest exploration goal (a
frontier of the map, a closed door with unexplored space behind it, a closed container).

Every method returns one action (or a verdict) and never talks to the host: the blocking
skills (``_skills.Skills``) and the Track 1 baselines (``examples/track1_common``) drive it.
It reads only what the host sends the agent: the observation's odometry, range scan, room
sign, hand, collision flag and detections.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from simhost.client.skills._mapping import Grid
from simhost.client.skills._model import Thing, WorldModel
from simhost.client.skills._navigation import (
    Action,
    DoorOpener,
    GoalFn,
    Navigator,
    Pose,
    door_normal,
    face,
    facing,
    near,
    reach_radius,
)


class Explorer:
    """The agent's map, model and motion (see the module).

    Attributes:
        grid: The occupancy grid, 10 cm cells, from range scans and collisions.
        model: The world model: rooms, doors, connections, containers, objects, tools.
        nav: The navigator over ``grid`` and ``model``.
        step: The agent's step counter (stamped on sightings; the caller advances it).
        pose: ``(x, y, yaw)`` from the odometry.
        room, room_type: The room of the last sign passed (-1 and "" before the first).
        held: The id of the thing in the hand, -1 when empty.
        collided: Whether the last move hit something.
        seen_now: The ids detected in the last observation.
        poses: Per room, the points the robot passed (0.5 m apart).
    """

    def __init__(self) -> None:
        self.grid = Grid()
        self.model = WorldModel()
        self.nav = Navigator(self.grid, self.model)
        self.step = 0
        self.pose: Pose = (0.0, 0.0, 0.0)
        self.room, self.room_type = -1, ""
        self.held = -1
        self.collided = False
        self.seen_now: set[int] = set()
        self.poses: dict[int, list[tuple[float, float]]] = {}
        self.radius: dict[int, float] = {}
        """Per thing, how close to its centre to stand to act on it (learned on failures)."""
        self.unsided: set[int] = set()
        """Things to approach from any side (their seen-from side was unreachable)."""
        self.turns = 0
        self.goal: tuple | None = None
        """The exploration goal being pursued: ("frontier", point), ("door", id, opener) or
        ("container", id)."""
        self.opener: DoorOpener | None = None
        self.failed: set[int] = set()
        """Doors and containers exploration gave up on."""
        self.blacklist: list[tuple[float, float]] = []
        """Frontier points exploration could not reach."""

    # ------------------------------------------------------------------ perception
    def sense(self, obs: Mapping[str, Any]) -> list[Thing]:
        """Adds one observation to the map and the model; returns the things seen now."""
        x, y, yaw = (float(v) for v in obs["odometry"])
        self.pose = (x, y, yaw)
        if int(obs["room"][0]) >= 0:  # a sign by the doorway: the room just entered
            self.room, self.room_type = int(obs["room"][0]), obs["room_name"]
        room = self.room
        self.held = int(obs["held"][0])
        result = obs["action_result"]
        self.collided = bool(result.get("collided"))
        dets = obs["detections"]
        self.seen_now = {d["id"] for d in dets}
        self.grid.scan(x, y, yaw, np.asarray(obs["range_scan"], float))
        if self.collided:  # something the scan missed (a door's edge): block that way
            for a in np.linspace(-0.7, 0.7, 7):
                self.grid.mark(x + 0.34 * math.cos(yaw + a), y + 0.34 * math.sin(yaw + a), 6)
        seen = self.model.observe(self.pose, room, self.room_type, dets, self.step)
        for t in seen:
            if t.kind == "door":
                if t.state == "open":
                    self.grid.clear(*t.position, 0.45)
                else:
                    self.grid.mark(*t.position, 6)
        trail = self.poses.setdefault(room, [])
        if not trail or math.dist(trail[-1], (x, y)) > 0.5:
            trail.append((x, y))
        return seen

    # ------------------------------------------------------------------ reaching things
    def act_on(self, thing: Thing, primitive: str, **extra: Any) -> Action | None:
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
        turn = face(self.pose, thing.position)
        if turn is not None and self.turns < 4:
            self.turns += 1  # the detector sees ahead only: face the thing first
            return turn
        self.turns = 0
        self.radius[thing.id] = max(0.5, radius - 0.15)
        return {"primitive": primitive, "target": thing.id, **extra}

    def box_of(self, item: Thing) -> Thing | None:
        """The container an item was seen in, if any."""
        return min((c for c in self.model.of_kind("container")
                    if math.dist(c.position, item.position) < 0.7),
                   key=lambda c: math.dist(c.position, item.position), default=None)

    def in_room(self, goal: GoalFn, room: int | None) -> GoalFn:
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

    # ------------------------------------------------------------------ exploration
    def pursue(self) -> Action | None:
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

    def frontiers(self, dist: np.ndarray, lo: np.ndarray) -> np.ndarray:
        """The reachable frontier cells worth going to, in the window of ``dist`` (whose
        corner is grid cell ``lo``): with enough unknown space around them, away from spots
        set aside and from closed doors (a door is a goal of its own)."""
        h, w = dist.shape
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
        return frontier

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
        frontier = self.frontiers(dist, lo)
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
