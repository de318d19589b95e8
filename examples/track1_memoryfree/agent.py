"""Track 1 memory-free reactive baseline (paper Table IV): the current observation and the
instruction, no persistent map or object memory.

Every step it looks at what is visible now: when the thing the task needs next (the item,
then where it goes or what it acts on) is in sight, it drives to it, avoiding obstacles in
the range scan, and acts; otherwise it wanders, preferring open doorways and opening
closed doors it bumps into. A locked door or an unavailable container in sight is logged
as an exception. Its world model is what it sees when a stage ends. The only state kept
between steps is a step counter (after a while it accepts another tool with the same use)
and the wander heading. Uses only ``simhost.agent.RemoteEnv``, numpy and the standard
library.
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

from simhost.agent import RemoteEnv, TimeStep

OUT = Path(os.environ.get("EAGC_OUTPUT", "/output"))
AFFORDANCES = {"sponge": "wipe", "cloth": "wipe", "knife": "cut", "scissors": "cut",
               "watering_can": "water", "jug": "water"}
ROOM_WORDS = {"living room": "living_room", "storage room": "storage"}
REACH = {"object": 1.0, "tool": 1.0, "door": 1.3}
SIZES = {"table": 0.5, "counter": 0.55, "shelf": 0.4, "bed": 0.9, "desk": 0.45, "sofa": 0.6,
         "cabinet": 0.4, "drawer": 0.4, "fridge": 0.45, "bin": 0.3}
PATIENCE = 150


def parse_instruction(text: str) -> dict[str, Any] | None:
    def name(words: str) -> str:
        return ROOM_WORDS.get(words, words.replace(" ", "_"))

    m = re.match(r"(?:put|place) the (\w+) (.+?) (in|on) the (.+?) in the (.+)$", text)
    if m:
        return {"kind": "place", "item": (name(m[2]), m[1]), "dest": (name(m[4]), name(m[5]))}
    m = re.match(r"(clean|slice|water) the (.+?) with the (\w+) (.+)$", text)
    if m:
        where = re.match(r"(.+?) in the (.+)$", m[2])
        target = ((name(where[1]), None, name(where[2])) if where
                  else (name(m[2].split(" ", 1)[1]), m[2].split(" ", 1)[0], None))
        return {"kind": "use", "item": (name(m[4]), m[3]), "target": target,
                "affordance": {"clean": "wipe", "slice": "cut", "water": "water"}[m[1]]}
    return None


class Agent:
    def __init__(self, seed: int = 1) -> None:
        self.rng = np.random.default_rng(seed)
        self.step = 0
        self.exec_steps = 0
        self.heading = 0.0
        self.task: dict[str, Any] | None = None
        self.done = False
        self.logged: set[str] = set()
        self.log = (OUT / "episode_log.jsonl").open("a")

    def record(self, event: str, stage: str, exception_type: str | None = None,
               **data: Any) -> None:
        rec: dict[str, Any] = {"step": self.step, "stage": stage, "event": event, "data": data}
        if exception_type:
            rec["exception_type"] = exception_type
        self.log.write(json.dumps(rec) + "\n")
        self.log.flush()

    # ------------------------------------------------------------------ what it sees
    @staticmethod
    def seen(obs: dict) -> list[dict[str, Any]]:
        out = obs["detections"]
        for d in out:
            d["dist"] = math.hypot(*d["rel_pos"])
            d["bearing"] = math.atan2(d["rel_pos"][1], d["rel_pos"][0])
        return out

    def write_model(self, obs: dict) -> None:
        """The world model of this one observation."""
        x, y, yaw = (float(v) for v in obs["odometry"])
        room = int(obs["room"][0])
        c, s = math.cos(yaw), math.sin(yaw)
        doc: dict[str, Any] = {"version": "eagc-world-model/v1", "step": self.step,
                               "rooms": [{"id": room, "type": obs["room_name"]}], "doors": [],
                               "containers": [], "objects": [], "affordances": []}
        for d in self.seen(obs):
            dx, dy = d["rel_pos"]
            if d["kind"] == "door":
                doc["doors"].append({"id": d["id"], "state": d["state"]})
            elif d["kind"] == "container":
                doc["containers"].append({"id": d["id"], "type": d["category"], "room": room,
                                          "state": d["state"]})
            elif d["kind"] in ("object", "tool"):
                doc["objects"].append({"id": d["id"], "category": d["category"],
                                       "colour": d["colour"], "room": room,
                                       "position": [x + c * dx - s * dy, y + s * dx + c * dy]})
                if d["category"] in AFFORDANCES:
                    doc["affordances"].append({"tool": d["id"],
                                               "affordance": AFFORDANCES[d["category"]]})
        tmp = OUT / ".world_model.json.tmp"
        tmp.write_text(json.dumps(doc))
        tmp.replace(OUT / "world_model.json")

    # ------------------------------------------------------------------ motion
    def toward(self, obs: dict, bearing: float, dist: float) -> dict[str, Any]:
        """A move toward a bearing (robot frame), steering to the nearest direction the range
        scan shows clear for the robot's width."""
        scan = np.asarray(obs["range_scan"], float)
        n = len(scan)
        need = min(dist, 1.0) + 0.1
        clear = np.ones(n, bool)
        for k in (-2, -1, 0, 1, 2):
            clear &= np.roll(scan, k) > (need if k == 0 else need * 0.8)
        angles = np.arange(n) * (2 * math.pi / n)
        diff = np.abs(np.remainder(angles - bearing + math.pi, 2 * math.pi) - math.pi)
        if clear.any():
            bearing = float(angles[np.argmin(np.where(clear, diff, 9.0))])
        else:
            bearing = float(angles[np.argmax(scan)])
        bearing = math.remainder(bearing, math.tau)
        if abs(bearing) > math.pi / 4:
            return {"primitive": "move", "move": [0.0, math.copysign(1.0, bearing)]}
        return {"primitive": "move", "move": [min(1.0, max(0.2, dist / 0.5)),
                                              bearing / (math.pi / 4)]}

    def wander(self, obs: dict, dets: list[dict]) -> dict[str, Any]:
        """Open a closed door ahead; head for an open doorway now and then; else keep a
        heading through open space, choosing a new one when blocked."""
        if int(obs["collided"][0]):  # back off, turned a little, and pick a new heading
            self.heading += float(self.rng.uniform(1.5, 4.5))
            return {"primitive": "move",
                    "move": [-0.5, float(self.rng.choice([-1.0, 1.0]) * self.rng.uniform(0.4, 1))]}
        for d in dets:
            if (d["kind"] == "door" and d["state"] == "closed" and d["dist"] < 1.45
                    and abs(d["bearing"]) < 1.0):
                return {"primitive": "open", "target": d["id"]}
        yaw = float(obs["odometry"][2])
        doors = [d for d in dets if d["kind"] == "door" and d["state"] == "open"]
        near = [d for d in doors if d["dist"] < 1.2 and abs(d["bearing"]) < 0.6]
        if near and self.rng.random() < 0.7:  # in a doorway: go on through
            self.heading = yaw + near[0]["bearing"]
            return self.toward(obs, near[0]["bearing"], 1.0)
        if doors and self.rng.random() < 0.3:
            d = doors[int(self.rng.integers(len(doors)))]
            self.heading = yaw + d["bearing"]
        scan = np.asarray(obs["range_scan"], float)
        ahead = math.remainder(self.heading - yaw, math.tau)
        k = int(round(ahead / (2 * math.pi / len(scan)))) % len(scan)
        if scan[k] < 1.0 or self.rng.random() < 0.05:
            long = np.flatnonzero(scan > max(1.5, 0.6 * scan.max()))
            pick = int(self.rng.choice(long)) if len(long) else int(np.argmax(scan))
            self.heading = yaw + pick * 2 * math.pi / len(scan)
            ahead = math.remainder(self.heading - yaw, math.tau)
        return self.toward(obs, ahead, 1.0)

    # ------------------------------------------------------------------ the task
    def wanted(self, obs: dict, dets: list[dict]) -> tuple[dict | None, str, dict]:
        """What to act on now, if it is in sight: (detection, primitive, extra fields)."""
        t = self.task
        assert t is not None
        held = int(obs["held"][0])
        cat, colour = t["item"]

        def item_ok(d: dict) -> bool:
            if d["category"] == cat and d["colour"] == colour:
                return True
            return (t["kind"] == "use" and self.exec_steps > PATIENCE
                    and AFFORDANCES.get(d["category"]) == t["affordance"])

        if held < 0:
            items = [d for d in dets if d["kind"] in ("object", "tool") and item_ok(d)]
            return (min(items, key=lambda d: d["dist"]) if items else None), "pick", {}
        if t["kind"] == "place":
            rcat, room_type = t["dest"]
            here = obs["room_name"] == room_type
            dests = [d for d in dets if here and d["kind"] in ("furniture", "container")
                     and d["state"] != "unavailable"
                     and (d["category"] == rcat or (d["kind"] == "container" and any(
                         x["category"] == rcat and x["state"] == "unavailable" for x in dets)))]
            dest = min(dests, key=lambda d: (d["category"] != rcat, d["dist"]), default=None)
            if dest is not None and dest["state"] == "closed":
                return dest, "open", {}
            return dest, "place", {}
        tcat, tcolour, room_type = t["target"]
        targets = [d for d in dets if d["category"] == tcat
                   and (tcolour is None or d["colour"] == tcolour)
                   and (room_type is None or obs["room_name"] == room_type)]
        return (targets[0] if targets else None), "use", {"tool": held}

    def act(self, obs: dict, dets: list[dict], stage: str) -> dict[str, Any]:
        for d in dets:
            if d["kind"] == "door" and d["state"] == "locked" and "door_lock" not in self.logged:
                self.logged.add("door_lock")
                self.record("exception_detected", stage, "door_lock", door=d["id"])
            if d["state"] == "unavailable" and "container_unavailable" not in self.logged:
                self.logged.add("container_unavailable")
                self.record("exception_detected", stage, "container_unavailable",
                            container=d["id"])
        thing, primitive, extra = self.wanted(obs, dets)
        if thing is None or int(obs["collided"][0]):
            return self.wander(obs, dets)
        reach = REACH.get(thing["kind"], SIZES.get(thing["category"], 0.5) + 0.55)
        if thing["dist"] <= reach:
            return {"primitive": primitive, "target": thing["id"], **extra}
        return self.toward(obs, thing["bearing"], thing["dist"])

    # ------------------------------------------------------------------ the loop
    def run(self, env: RemoteEnv) -> None:
        env.hello(agent="eagc-track1-memoryfree/1")
        ts: TimeStep = env.reset()
        explore_steps = 30
        while not ts.episode_over:
            obs = ts.observation
            for m in ts.messages:
                if m.type == "instruction" and "steps" in m.data:
                    self.task = parse_instruction(m.data["text"])
            dets = self.seen(obs)
            if ts.stage == "exploration":
                if explore_steps <= 0 or (ts.steps_left is not None and ts.steps_left <= 1):
                    self.write_model(obs)
                    ts = env.end_stage()
                    continue
                explore_steps -= 1
                action = self.wander(obs, dets)
            elif ts.stage == "planning":
                queries = next((m.data["queries"] for m in ts.messages if m.type == "queries"),
                               [])
                visible = {d["id"]: d for d in dets}
                answers = {q["id"]: visible[q["door"]]["state"] for q in queries
                           if q["kind"] == "door_state" and q["door"] in visible}
                if answers:
                    ts = env.answer(answers)
                self.record("plan", ts.stage, task=self.task)
                ts = env.end_stage({"plan": {"subgoals": []}})
                continue
            else:
                self.exec_steps += 1
                last_ok = obs["action_result"]
                if self.done or self.task is None or (ts.steps_left is not None
                                                      and ts.steps_left <= 1):
                    action = {"primitive": "done"}
                else:
                    action = self.act(obs, dets, ts.stage)
                    reason = "" if last_ok.get("ok", True) else last_ok.get("reason", "")
                    if reason and action["primitive"] != "move":  # react to the failure
                        action = {"primitive": "move", "move": {
                            "out_of_reach": [0.4, 0.0], "blocked_by_robot": [-0.6, 0.0],
                        }.get(reason, [0.0, float(self.rng.choice([-1.0, 1.0]))])}
            self.step += 1
            ts = env.step(action)
            if (action["primitive"] in ("place", "use") and ts.action is not None
                    and ts.action.ok):
                self.done = True
        self.write_model(ts.observation)
        self.record("note", ts.stage, end=ts.end_reason)


def main() -> int:
    with RemoteEnv() as env:
        Agent().run(env)
    return 0


if __name__ == "__main__":
    sys.exit(main())
