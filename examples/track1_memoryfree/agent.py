"""Track 1 memory-free reactive baseline (paper Table IV): the current observation and the
instruction, no persistent map or object memory.

Every step it looks at what the detector reports now: when the thing the current goal needs
next (the item, then where it goes or what it acts on) is in sight, it turns to it, drives
to it avoiding obstacles in the range scan, and acts; otherwise it goes to look closely at
the piece of furniture in view that most likely holds it (priors learned offline on
generated houses, ``priors.npz``, the look-ahead planner's: the policy's weights, not a
memory), opening closed containers; with none in view it searches by following the walls on
its right hand (furniture stands against walls, so this passes close to every surface and
through every open doorway), opening closed doors ahead. A failed ``open`` or
``place`` that says ``locked`` or ``unavailable`` is logged as an exception. During
exploration it follows the walls and reports every sighting to ``world_model.json`` (a
write-only report: it never reads it back). Between steps it keeps only what a reactive policy
needs to act at all: which goal of the instruction it is on (``parsing.py``), the room
whose sign it read last, how long ago (after a while, or when the goal names another room,
it leaves through a doorway in sight), the id of what it is approaching while that stays
in view, and a step counter (after a while it accepts another tool with the same use). The
last action's result is part of what it sees: it steps back when it stands in a door's way
or a turn hits something. Uses only ``simhost.agent`` (``RemoteEnv``, ``OutputFiles``),
numpy and the standard library.
"""

from __future__ import annotations

import math
import sys
from typing import Any

import numpy as np
from parsing import AFFORDANCES, parse
from priors import Priors

from simhost.agent import OutputFiles, RemoteEnv, TimeStep

REACH = {"object": 1.0, "tool": 1.0, "door": 1.3}
SIZES = {"table": 0.5, "counter": 0.55, "shelf": 0.4, "bed": 0.9, "desk": 0.45, "sofa": 0.6,
         "cabinet": 0.4, "drawer": 0.4, "fridge": 0.45, "bin": 0.3}
PATIENCE = 150
ROOM_PATIENCE = 40
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
"""Closer than this, what rests on a piece of furniture would be in sight."""


class Agent:
    def __init__(self, seed: int = 1) -> None:
        self.rng = np.random.default_rng(seed)
        self.priors = Priors()
        self.files = OutputFiles()
        self.step = 0
        self.exec_steps = 0
        self.goals: list[dict[str, Any]] = []
        self.current = 0
        self.room, self.room_type = -1, ""
        self.logged: set[str] = set()
        self.last: dict[str, Any] | None = None
        self.drop = False
        self.in_room = 0
        self.stuck = 0
        self.report: dict[str, dict[int, dict[str, Any]]] = {
            k: {} for k in ("rooms", "doors", "containers", "objects", "affordances")}

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
        doors = [d for d in dets if d["kind"] == "door" and d["id"] not in self.locked_now]
        leave = self.in_room > ROOM_PATIENCE or (self.goals and self.current < len(
            self.goals) and self.leaving(obs))
        if leave and doors and not int(obs["collided"][0]):
            door = min(doors, key=lambda d: d["dist"])
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
                    and abs(d["bearing"]) < 0.6 and d["id"] not in self.locked_now):
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
    def fits(self, d: dict, ref: dict, *, here: bool = True) -> bool:
        """Whether a detection fits a description (its room only when known now)."""
        if d["category"] != ref["category"]:
            return False
        if ref.get("colour") and d["colour"] != ref["colour"]:
            return False
        return not (here and ref.get("room") and self.room_type
                    and self.room_type != ref["room"])

    def wanted(self, obs: dict, dets: list[dict]) -> tuple[dict | None, str, dict]:
        """What to act on now, if it is in sight: (detection, primitive, extra fields)."""
        goal = self.goals[self.current]
        held = int(obs["held"][0])
        ref = goal["item"] if goal["kind"] == "place" else goal["tool"]

        def item_ok(d: dict) -> bool:
            if self.fits(d, ref):
                return True
            return (goal["kind"] == "use" and self.exec_steps > PATIENCE
                    and AFFORDANCES.get(d["category"]) == goal["affordance"])

        if held < 0:
            items = [d for d in dets if d["kind"] in ("object", "tool") and item_ok(d)]
            return (min(items, key=lambda d: d["dist"]) if items else None), "pick", {}
        if goal["kind"] == "place":
            dest = goal["dest"]
            here = self.room_type == dest["room"]
            dests = [d for d in dets if here and d["kind"] in ("furniture", "container")
                     and d["id"] not in self.unusable
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
        """The piece of furniture in view most likely to hold what is wanted (learned priors
        over furniture category and this room's type), among those ahead and not yet close
        (close up, what is on it would be in sight)."""
        category, room, on = self.wanted_now(obs)
        if room is not None and self.room_type and self.room_type != room:
            return None
        best, best_p = None, 0.04
        for d in dets:
            if d["kind"] not in ("furniture", "container") or abs(d["bearing"]) > 1.0:
                continue
            if d["dist"] < (1.2 if d["kind"] == "container" and d["state"] == "closed"
                            else CLOSE):
                continue
            p = self.priors.where(category, d["category"], self.room_type or None)
            if on is not None:  # the instruction says what it rests on
                p = 1.0 if d["category"] == on else 0.0
            if p / (1 + d["dist"] / 3) > best_p:
                best, best_p = d, p / (1 + d["dist"] / 3)
        return best

    def wanted_now(self, obs: dict) -> tuple[str, str | None, str | None]:
        """The category needed next, the room the instruction names for it and what the
        instruction says it rests on."""
        goal = self.goals[self.current]
        if int(obs["held"][0]) < 0:
            ref = goal["item"] if goal["kind"] == "place" else goal["tool"]
        else:
            ref = goal["dest"] if goal["kind"] == "place" else goal["target"]
        return ref["category"], ref.get("room"), ref.get("on")

    def act(self, obs: dict, dets: list[dict], stage: str) -> dict[str, Any]:
        if self.drop and int(obs["held"][0]) >= 0:  # the tool just used is not needed now
            spots = [d for d in dets if d["kind"] == "furniture"]
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
            again = [d for d in dets if d["id"] == self.lock[1]]
            if again:
                thing, primitive, extra = again[0], self.lock[2], self.lock[3]
            else:
                self.lock = None
        if thing is None and not int(obs["collided"][0]):
            place = self.promising(obs, dets)
            if place is not None:  # go and look at it from close up
                if place["kind"] == "container" and place["state"] == "closed":
                    if place["dist"] <= SIZES.get(place["category"], 0.5) + 0.55:
                        return {"primitive": "open", "target": place["id"]}
                return self.toward(obs, place["bearing"], place["dist"])
        if (thing is None and self.in_room < LOOK_AROUND and not int(obs["collided"][0])
                and not self.leaving(obs)):
            return {"primitive": "move", "move": [0.0, 1.0]}  # just in: look around
        if thing is None or int(obs["collided"][0]):
            return self.wander(obs, dets, self.room_wanted(obs))
        if self.stuck >= 3:  # the way to it is blocked: search on
            self.stuck = 0
            return self.follow_wall(obs, dets)
        reach = REACH.get(thing["kind"], SIZES.get(thing["category"], 0.5) + 0.55)
        if abs(thing["bearing"]) > 0.6:
            return {"primitive": "move", "move": [0.0, max(-1.0, min(1.0, thing["bearing"]
                                                                    / (math.pi / 4)))]}
        if thing["dist"] <= reach:
            return {"primitive": primitive, "target": thing["id"], **extra}
        return self.toward(obs, thing["bearing"], thing["dist"])

    def leaving(self, obs: dict) -> bool:
        """Whether the goal names another room than this one, or names none and what is
        wanted is unlikely in a room of this type (the learned priors)."""
        room = self.room_wanted(obs)
        if room is not None:
            return bool(self.room_type and self.room_type != room)
        category, _, _ = self.wanted_now(obs)
        return self.priors.room_share(category, self.room_type or None) < UNLIKELY

    def room_wanted(self, obs: dict) -> str | None:
        """The room type the goal names for what is needed next, if any."""
        goal = self.goals[self.current]
        if int(obs["held"][0]) < 0:
            ref = goal["item"] if goal["kind"] == "place" else goal["tool"]
            return ref.get("room")
        return (goal["dest"] if goal["kind"] == "place" else goal["target"]).get("room")

    def failure(self, ts: TimeStep, stage: str) -> None:
        """A failed action that says what is wrong: a locked door, an unusable container."""
        result = ts.observation["action_result"]
        self.locked_now = set()
        self.unusable = set()
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
        if reason == "locked":
            self.locked_now = {target}
            kind = "door_lock"
        elif reason == "unavailable":
            self.unusable = {target}
            kind = "container_unavailable"
        else:
            return
        if stage == "execution" and kind not in self.logged:
            self.logged.add(kind)
            self.record("exception_detected", stage, kind, target=target)

    # ------------------------------------------------------------------ the loop
    def run(self, env: RemoteEnv) -> None:
        env.hello(agent="eagc-track1-memoryfree/2")
        ts: TimeStep = env.reset()
        self.locked_now: set[int] = set()
        self.unusable: set[int] = set()
        self.nudge: dict[str, Any] | None = None
        self.lock: tuple | None = None
        while not ts.episode_over:
            obs = ts.observation
            self.in_room += 1
            self.stuck = self.stuck + 1 if int(obs["collided"][0]) else 0
            if int(obs["room"][0]) >= 0:
                self.room, self.room_type = int(obs["room"][0]), obs["room_name"]
                self.in_room = 0
            for m in ts.messages:
                if m.type == "instruction" and "text" in m.data:
                    self.goals = parse(m.data["text"])
            self.failure(ts, ts.stage)
            dets = self.seen(obs)
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
                answers = {q["id"]: visible[q["door"]]["state"] for q in queries
                           if q["kind"] == "door_state" and q.get("door") in visible}
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


def main() -> int:
    with RemoteEnv() as env:
        Agent().run(env)
    return 0


if __name__ == "__main__":
    sys.exit(main())
