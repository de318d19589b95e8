"""What the vision baseline puts between the host and a planner written for detections.

``SeeingEnv`` wraps the ``RemoteEnv`` of a split without a detector (``vision``): each
observation it returns gains ``detections`` (the learned detector's, ``detector.Detector``,
under ids of the agent's own, ``Tracker``) and ``held`` as an id (the host says only whether
the hand holds something), and each action that names a thing by id leaves as an action by
pixel: the pixel of that thing's segment in the last frame (``detector.nearest_pixel``),
else the pixel its remembered position projects to. So the structured planner
(``examples/track1_structured``) plays the ``vision`` split unchanged, on what the camera
shows.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from detector import EYE, FOVY, TILT, Detector

from simhost.client import RemoteEnv, TimeStep

MATCH = {"item": 0.45, "door": 1.0, "big": 0.9}
"""How far (metres) a sighting may lie from a remembered thing of its group to be it."""
HEIGHT = {"item": 0.8, "door": 1.0, "big": 0.5}
"""The height (metres) aimed at when a thing is not in the last frame."""
STUCK = 3
"""Moves in a row that collided before the robot backs off whatever the planner asked: a
robot wedged against something its camera misread (a table edge, a door swung open)."""
HAND = (0.38, 0.0)
"""Where the hand holds an item, in the robot's frame (x ahead, y left; metres): what it
holds shows there in the frame and is no thing of the house."""


def _group(kind: str) -> str:
    return "item" if kind in ("object", "tool") else "door" if kind == "door" else "big"


def door_state(rel_pos: tuple[float, float], seen: str, scan: np.ndarray) -> str:
    """A door's state, the camera's reading checked against the range scan's rays toward
    its doorway (those within 0.3 m of its centre): one that passes the doorway says open,
    all stopped there say shut (the planner clears its map at an open door, so an open
    door that is not one would open a way through a wall); rays stopped well before it
    (something in between) leave the reading as it is."""
    dist = math.hypot(*rel_pos)
    step = 2 * math.pi / len(scan)
    bearing = math.atan2(rel_pos[1], rel_pos[0])
    half = max(math.atan2(0.3, max(dist, 0.1)), step / 2)
    rays = [float(scan[k % len(scan)])
            for k in range(math.floor((bearing - half) / step),
                           math.ceil((bearing + half) / step) + 1)
            if abs((k * step - bearing + math.pi) % (2 * math.pi) - math.pi) <= half]
    if rays and max(rays) >= dist + 0.5:
        return "open"
    if rays and min(rays) >= dist - 0.4:
        return "closed"
    return seen


class Tracker:
    """Gives each thing the detector finds an id of its own, the same at every sighting:
    a sighting is the nearest unclaimed remembered thing of its group (items, doors, the
    rest) within ``MATCH``, else a new thing."""

    def __init__(self) -> None:
        self.places: dict[int, tuple[str, float, float, float]] = {}
        """Per id: (group, x, y, height) where it was seen last (world frame)."""
        self.next_id = 1

    def assign(self, pose: tuple[float, float, float],
               found: list[dict[str, Any]]) -> list[dict[str, Any]]:
        x, y, yaw = pose
        c, s = math.cos(yaw), math.sin(yaw)
        claimed: set[int] = set()
        for d in found:
            rx, ry = d["rel_pos"]
            wx, wy = x + c * rx - s * ry, y + s * rx + c * ry
            group = _group(d["kind"])
            best, gap = None, MATCH[group]
            for i, (g, px, py, _h) in self.places.items():
                dist = math.hypot(px - wx, py - wy)
                if g == group and i not in claimed and dist < gap:
                    best, gap = i, dist
            if best is None:
                best = self.next_id
                self.next_id += 1
            claimed.add(best)
            d["id"] = best
            self.places[best] = (group, wx, wy, d.get("height", HEIGHT[group]))
        return found


class SeeingEnv:
    """A ``RemoteEnv`` seen through the detector (see the module)."""

    def __init__(self, env: RemoteEnv, detector: Detector | None = None) -> None:
        self.env = env
        self.detector = detector or Detector()
        self.tracker = Tracker()
        self.frame: list[dict[str, Any]] = []
        self.shape: tuple[int, int] = (192, 256)
        self.pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self.held = -1
        self.told: dict[int, str] = {}
        """Door states the host's answers taught (``already_open``, a door that bumped the
        robot): they outweigh the camera's reading."""
        self.stuck = 0
        """Moves in a row that collided."""

    def __getattr__(self, name: str) -> Any:
        return getattr(self.env, name)

    # ------------------------------------------------------------------ the host's calls
    def reset(self) -> TimeStep:
        return self._see(self.env.reset())

    def step(self, action: dict[str, Any]) -> TimeStep:
        if action.get("primitive") == "move" and self.stuck >= STUCK:
            action = {"primitive": "move", "move": [-0.5, 0.0]}  # wedged: back off first
            self.stuck = 0
        ts = self._see(self.env.step(self._by_pixel(action)), action)
        collided = ts.action is not None and ts.action.reason == "collided"
        self.stuck = self.stuck + 1 if collided and action.get("primitive") == "move" else 0
        return ts

    def answer(self, answers: dict[str, Any]) -> TimeStep:
        return self._see(self.env.answer(answers))

    def end_stage(self, payload: dict[str, Any] | None = None) -> TimeStep:
        return self._see(self.env.end_stage(payload))

    # ------------------------------------------------------------------ seeing
    def _see(self, ts: TimeStep, action: dict[str, Any] | None = None) -> TimeStep:
        obs = dict(ts.observation)
        if "rgb" not in obs:
            return ts
        rgb, depth = np.asarray(obs["rgb"]), np.asarray(obs["depth"])
        self.shape = depth.shape
        self.pose = tuple(float(v) for v in obs["odometry"])  # type: ignore[assignment]
        found = self.detector.detect(rgb, depth)
        holding = bool(int(np.asarray(obs["held"]).ravel()[0]))
        if holding:
            found = [d for d in found if d["kind"] not in ("object", "tool")
                     or math.dist(d["rel_pos"], HAND) > 0.3]
        scan = np.asarray(obs.get("range_scan", ()), float)
        if scan.size:
            for d in found:
                if d["kind"] == "door":
                    d["state"] = door_state(d["rel_pos"], d["state"], scan)
        self.frame = self.tracker.assign(self.pose, found)
        self.learn(action, ts)
        for d in self.frame:
            if d["id"] in self.told:
                d["state"] = self.told[d["id"]]
        ok = ts.action is not None and ts.action.ok
        if action is not None and ok and action.get("primitive") == "pick":
            self.held = int(action.get("target", -1))
        if not holding:
            self.held = -1
        obs["held"] = np.array([self.held if holding else -1], np.int32)
        obs["detections"] = [{k: d[k] for k in ("id", "kind", "category", "colour", "state",
                                                 "rel_pos")} for d in self.frame]
        return ts._replace(observation=obs)

    def learn(self, action: dict[str, Any] | None, ts: TimeStep) -> None:
        """What the host's answer to an action says of a door's state."""
        if action is None or ts.action is None:
            return
        target, reason = action.get("target"), ts.action.reason
        group = self.tracker.places.get(int(target), ("",))[0] if target is not None else ""
        if action.get("primitive") == "open" and target is not None and (
                ts.action.ok or reason == "already_open"
                or (group == "door" and reason == "nothing_there")):
            self.told[int(target)] = "open"  # (a doorway with nothing in it is open)
        elif action.get("primitive") == "close" and target is not None and (
                ts.action.ok or reason == "already_closed"):
            self.told[int(target)] = "closed"
        if action.get("primitive") == "move" and reason == "collided":
            x, y, _ = self.pose
            for i, (group, px, py, _h) in self.tracker.places.items():
                if group == "door" and math.hypot(px - x, py - y) < 0.9:
                    self.told[i] = "closed"  # a doorway the robot cannot pass

    # ------------------------------------------------------------------ acting
    def _by_pixel(self, action: dict[str, Any]) -> dict[str, Any]:
        """An action naming things by id, as the pixel split takes it."""
        out = {k: v for k, v in action.items() if k not in ("target", "tool")}
        if "target" in action:
            out["target_px"] = self.pixel_of(int(action["target"]))
        tool = action.get("tool")
        if tool is not None and int(tool) != self.held:
            out["tool_px"] = self.pixel_of(int(tool))
        return out

    def pixel_of(self, thing: int) -> list[int]:
        """The pixel ``[u, v]`` of a thing in the last frame: its segment's; else the
        segment of the frame's thing of its group nearest its remembered place (within
        1.5 m: a sighting the tracker took for another); else where that place projects
        (clamped into the frame)."""
        for d in self.frame:
            if d["id"] == thing:
                return list(d["pixel"])
        group, px, py, height = self.tracker.places.get(thing, ("big", *self.pose[:2], 0.5))
        near = [(math.dist(self.tracker.places[d["id"]][1:3], (px, py)), k)
                for k, d in enumerate(self.frame) if _group(d["kind"]) == group]
        if near and min(near)[0] < 1.5:
            return list(self.frame[min(near)[1]]["pixel"])
        return self.project(px, py, height)

    def project(self, wx: float, wy: float, wz: float) -> list[int]:
        """The pixel a world point projects to (clamped into the frame)."""
        x, y, yaw = self.pose
        c, s = math.cos(yaw), math.sin(yaw)
        dx, dy = wx - x, wy - y
        rx, ry = c * dx + s * dy - EYE[0], -s * dx + c * dy
        rz = wz - EYE[2]
        ct, st = math.cos(TILT), math.sin(TILT)
        ahead = rx * ct - rz * st
        up = rx * st + rz * ct
        h, w = self.shape
        f = (h / 2) / math.tan(FOVY / 2)
        ahead = max(ahead, 0.1)
        u = w / 2 + (-ry) / ahead * f
        v = h / 2 - up / ahead * f
        return [int(min(max(u, 0), w - 1)), int(min(max(v, 0), h - 1))]
