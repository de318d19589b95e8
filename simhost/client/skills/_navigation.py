"""Navigation on the occupancy grid: go somewhere (opening closed doors on the way), open a
door, face a thing. Each returns the next action, or a verdict (one step at a time: the
blocking skills of ``_skills.py`` and the Track 1 baselines drive them).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from simhost.client.skills._mapping import Grid, steer
from simhost.client.skills._model import SIZES, Thing, WorldModel

Pose = tuple[float, float, float]
Action = dict[str, Any]
GoalFn = Callable[[np.ndarray, np.ndarray], np.ndarray]
REPLAN_EVERY = 6


def near(point: tuple[float, float], radius: float, inner: float = 0.0) -> GoalFn:
    """Goal cells within ``radius`` of a point (and beyond ``inner``)."""
    px, py = point

    def goal(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        d = np.hypot(xs - px, ys - py)
        return (d <= radius) & (d >= inner)

    return goal


def facing(point: tuple[float, float], radius: float, toward: tuple[float, float],
           half_angle: float = 1.0) -> GoalFn:
    """Goal cells within ``radius`` of a point, on the side facing ``toward`` (a thing in a
    container is seen only from its opening side: from where it was seen before)."""
    px, py = point
    ux, uy = toward[0] - px, toward[1] - py
    norm = math.hypot(ux, uy) or 1.0
    ux, uy = ux / norm, uy / norm
    cos = math.cos(half_angle)

    def goal(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        dx, dy = xs - px, ys - py
        d = np.hypot(dx, dy)
        return (d <= radius) & (dx * ux + dy * uy >= cos * np.maximum(d, 1e-6))

    return goal


def door_normal(grid: Grid, door: Thing, pose: Pose) -> tuple[float, float]:
    """The unit normal of a doorway's wall (walls are axis-aligned), pointing to the robot."""
    cx, cy = door.position
    occupied = grid.occupied()
    counts = []
    for ux, uy in ((1, 0), (0, 1)):
        n = 0
        for s in (-1, 1):
            for d in np.arange(0.6, 1.2, 0.1):
                i, j = grid.cell(cx + s * d * ux, cy + s * d * uy)
                n += int(occupied[i, j])
        counts.append(n)
    if counts[0] != counts[1]:
        normal = (0.0, 1.0) if counts[0] > counts[1] else (1.0, 0.0)  # wall along x → n = y
    else:
        dx, dy = pose[0] - cx, pose[1] - cy
        normal = (1.0, 0.0) if abs(dx) > abs(dy) else (0.0, 1.0)
    side = 1.0 if (pose[0] - cx) * normal[0] + (pose[1] - cy) * normal[1] >= 0 else -1.0
    return normal[0] * side, normal[1] * side


def reach_radius(t: Thing) -> float:
    """How close to a thing's centre the robot aims to stand to act on it."""
    if t.kind in ("object", "tool"):
        return 1.1
    w, d = SIZES.get(t.category, (1.0, 0.6))
    return 0.5 * math.hypot(w, d) + 0.45


def face(pose: Pose, point: tuple[float, float], tolerance: float = 0.6) -> Action | None:
    """A turn toward a point when it is more than ``tolerance`` (radians) off the heading,
    else None (the detector sees 60 degrees either side of ahead)."""
    want = math.atan2(point[1] - pose[1], point[0] - pose[0])
    err = math.remainder(want - pose[2], math.tau)
    if abs(err) <= tolerance:
        return None
    return {"primitive": "move", "move": [0.0, max(-1.0, min(1.0, err / (math.pi / 4)))]}


def escape_move(pose: Pose, clear: tuple[float, float]) -> list[float]:
    """A short move toward a clear point: forward if it is ahead, backward if behind."""
    dx, dy = clear[0] - pose[0], clear[1] - pose[1]
    dist = min(1.0, (math.hypot(dx, dy) + 0.05) / 0.5)
    err = math.remainder(math.atan2(dy, dx) - pose[2], math.tau)
    if abs(err) > math.pi / 2:  # behind: back up, turning the rear toward it
        err = math.remainder(err + math.pi, math.tau)
        dist = -dist
    return [dist if abs(err) < math.pi / 4 else 0.0, max(-1.0, min(1.0, err / (math.pi / 4)))]


class Navigator:
    """Follows a breadth-first path to a goal; opens closed doors in the way."""

    def __init__(self, grid: Grid, model: WorldModel) -> None:
        self.grid, self.model = grid, model
        self.key: Any = None
        self.path: list[tuple[float, float]] | None = None
        self.age = 0
        self.fails = 0
        self.last_pose: Pose | None = None
        self.stuck = 0
        self.backoffs = 0
        self.door: DoorOpener | None = None
        self.skip_doors: set[int] = set()
        self.horizon = 16
        """Path points (0.1 m apart) looked ahead for a straight line to drive."""

    def reset(self) -> None:
        self.key, self.path, self.door, self.fails = None, None, None, 0

    def _open_discs(self) -> list[tuple[float, float, float]]:
        return [(*t.position, 0.4) for t in self.model.of_kind("door")
                if t.state == "closed" and t.id not in self.skip_doors]

    def go(self, key: Any, goal: GoalFn, pose: Pose, collided: bool) -> Action | str:
        """The next action toward ``goal``; "arrived" or "unreachable" when there is none."""
        if key != self.key:
            self.reset()
            self.key = key
        if self.door is not None:
            step = self.door.step(pose)
            if isinstance(step, dict):
                return step
            if step == "failed":
                self.skip_doors.add(self.door.door.id)
            self.door, self.path = None, None
        moved = self.last_pose is not None and math.dist(self.last_pose[:2], pose[:2]) > 0.02
        turned = self.last_pose is not None and abs(self.last_pose[2] - pose[2]) > 0.02
        self.stuck = 0 if moved or turned else self.stuck + 1
        self.last_pose = pose
        if collided:  # get clear first: toward free space, else back, else ahead
            self.path = None
            self.backoffs += 1
            clear = self.grid.escape(pose[0], pose[1])
            options = [escape_move(pose, clear) if clear else [-0.4, 0.0], [-0.4, 0.0],
                       [0.4, 0.0], [0.0, 1.0]]
            return {"primitive": "move", "move": options[(self.backoffs - 1) % len(options)]}
        self.backoffs = 0
        if self.stuck >= 2:
            self.stuck = 0
            self.path = None
            return {"primitive": "move", "move": [0.0, 1.0 if self.backoffs % 2 else -1.0]}
        here = np.array([[pose[0]]]), np.array([[pose[1]]])
        if goal(*here)[0, 0]:
            return "arrived"
        clear = self.grid.escape(pose[0], pose[1])
        if clear is not None:  # too close to something: step away from it first
            self.path = None
            return {"primitive": "move", "move": escape_move(pose, clear)}
        self.age += 1
        if self.path is None or self.age >= REPLAN_EVERY:
            self.path = self.grid.plan(pose[:2], goal, opened=self._open_discs())
            self.age = 0
            if self.path is None and self.skip_doors:  # give the doors another chance
                self.skip_doors.clear()
                self.path = self.grid.plan(pose[:2], goal, opened=self._open_discs())
            if self.path is None:
                self.fails += 1
                if self.fails >= 3:
                    return "unreachable"
                return {"primitive": "move", "move": [0.0, 1.0]}
        door = self._closed_door_ahead(pose)
        if door is not None:
            self.door = DoorOpener(self.grid, self.model, door)
            return self.go(key, goal, pose, False)
        # Drop the path points already passed.
        k = int(np.argmin([math.dist(p, pose[:2]) for p in self.path[:30]]))
        self.path = self.path[k:]
        if len(self.path) <= 1:  # the robot's cell is a goal cell
            self.path = None
            return "arrived"
        move, _ = steer(pose, self.grid, self.path[1:], self.horizon)
        return {"primitive": "move", "move": move}

    def _closed_door_ahead(self, pose: Pose) -> Thing | None:
        if not self.path:
            return None
        ahead = self.path[:30]
        for t in self.model.of_kind("door"):
            if t.state != "closed" or t.id in self.skip_doors:
                continue
            if any(math.dist(p, t.position) < 0.45 for p in ahead):
                return t
        return None


class DoorOpener:
    """Stands clear of a door's swing, within reach, and opens it."""

    def __init__(self, grid: Grid, model: WorldModel, door: Thing) -> None:
        self.grid, self.model, self.door = grid, model, door
        self.distance = 1.35
        self.tries = 0
        self.nav_fails = 0
        self.path: list[tuple[float, float]] | None = None
        self.age = 0
        self.sent = 0

    def stand(self, pose: Pose) -> tuple[float, float]:
        nx, ny = door_normal(self.grid, self.door, pose)
        cx, cy = self.door.position
        return cx + nx * self.distance, cy + ny * self.distance

    def step(self, pose: Pose) -> Action | str:
        """An action, or "opened" / "failed"."""
        if self.door.state == "open":
            self.grid.clear(*self.door.position, 0.45)
            return "opened"
        if self.door.state == "locked" or self.tries >= 4 or self.nav_fails >= 12:
            return "failed"
        target = self.stand(pose)
        if math.dist(target, pose[:2]) <= 0.25:
            turn = face(pose, self.door.position)
            if turn is not None and self.sent < 3:
                self.sent += 1  # the camera sees ahead only: face the door first
                return turn
            self.tries += 1
            self.sent = 0
            return {"primitive": "open", "target": self.door.id}
        self.age += 1
        if self.path is None or self.age >= REPLAN_EVERY:
            self.age = 0
            self.path = self.grid.plan(pose[:2], near(target, 0.2))
        if not self.path or len(self.path) <= 1:
            self.nav_fails += 1
            self.path = None
            self.distance = 1.45 if self.distance < 1.4 else 1.25
            return {"primitive": "move", "move": [0.0, 0.5]}
        k = int(np.argmin([math.dist(p, pose[:2]) for p in self.path[:30]]))
        self.path = self.path[k:]
        move, _ = steer(pose, self.grid, self.path[1:] or self.path)
        return {"primitive": "move", "move": move}

    def result(self, reason: str) -> None:
        """Adjusts to the reason an ``open`` failed."""
        if reason == "blocked_by_robot":
            self.distance = 1.5
        elif reason in ("out_of_reach", "not_visible"):
            self.distance = max(0.9, self.distance - 0.2)
        elif reason == "already_open":
            self.door.state = "open"
        elif reason == "locked":
            self.door.state = "locked"
