"""A Track 1 agent that writes its files in the shapes of a team that built its stack
before eagc existed (issue 35): rooms as names, room links under
``topology[].frontiers[]``, doors and containers filed as objects, their states as
``{entity, attribute, value}`` triples, affordances as ``{object, actions}``, and log
records with ``event_type`` values of its own (``perception``,
``execution_exception``). It moves at random, never reports an exception in eagc's
words, and ends each stage as it should. Run by ``test_track1_near_miss.py``.
"""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from schemas import CONTAINER
from simhost.client import RemoteEnv

STEPS = {"exploration": 25, "execution": 15}


class Agent:
    def __init__(self) -> None:
        self.rng = np.random.default_rng(0)
        self.out = Path(os.environ.get(CONTAINER.env_output) or CONTAINER.output_dir)
        self.step = 0
        self.room = "unknown"
        self.rooms: list[str] = []
        self.seen: dict[int, dict[str, Any]] = {}
        self.log_lines: list[str] = []

    def log(self, event_type: str, **data: Any) -> None:
        self.log_lines.append(json.dumps({"step": self.step, "event_type": event_type,
                                          "notes": data}))
        self._write("episode_log.jsonl", "\n".join(self.log_lines) + "\n")

    def _write(self, name: str, text: str) -> None:
        tmp = self.out / f".{name}.tmp"
        tmp.write_text(text)
        tmp.replace(self.out / name)

    def look(self, obs: dict[str, Any]) -> None:
        if int(obs["room"][0]) >= 0 and obs["room_name"] not in self.rooms:
            self.room = str(obs["room_name"])
            self.rooms.append(self.room)
        x, y, yaw = (float(v) for v in obs["odometry"])
        for d in obs["detections"]:
            dx, dy = d["rel_pos"]
            self.seen[int(d["id"])] = {
                "id": int(d["id"]), "name": d["category"], "category": d["category"],
                "kind": d["kind"], "room": self.room, "state": d["state"],
                "position": [x + math.cos(yaw) * dx - math.sin(yaw) * dy,
                             y + math.sin(yaw) * dx + math.cos(yaw) * dy]}

    def write_model(self) -> None:
        things = list(self.seen.values())
        self._write("world_model.json", json.dumps({
            "episode_id": "team-shapes", "agent_state": {"step": self.step},
            "rooms": self.rooms,
            "topology": [{"room": r, "visited": True,
                          "frontiers": [{"target": f"door {t['id']}", "status": t["state"]}
                                        for t in things
                                        if t["kind"] == "door" and t["room"] == r]}
                         for r in self.rooms],
            "objects": [{k: v for k, v in t.items() if k != "kind"} for t in things],
            "states": [{"entity": t["id"], "attribute": "state", "value": t["state"]}
                       for t in things if t["kind"] in ("door", "container")],
            "affordances": [{"object": t["name"], "actions": [f"pick_up({t['name']})"]}
                            for t in things if t["kind"] in ("object", "tool")],
        }))

    def run(self, env: RemoteEnv) -> None:
        env.hello(agent="team-shapes/1")
        ts = env.reset()
        self.log("observation", stage=ts.stage)
        counts: dict[str, int] = {}
        while not ts.episode_over:
            self.look(ts.observation)
            if ts.stage == "planning":
                self.log("planning")
                ts = env.end_stage({})
                continue
            if counts.get(ts.stage, 0) >= STEPS.get(ts.stage, 0) or (
                    ts.steps_left is not None and ts.steps_left <= 1):
                if ts.stage == "exploration":
                    self.write_model()
                    ts = env.end_stage()
                else:
                    ts = env.step({"primitive": "done"})
                continue
            self.step += 1
            counts[ts.stage] = counts.get(ts.stage, 0) + 1
            self.log("perception" if ts.stage == "exploration" else "action")
            if ts.stage == "execution" and counts[ts.stage] == 2:
                self.log("execution_exception", type="object_relocated")
            turn, forward = self.rng.uniform(-1, 1), self.rng.uniform(0, 1)
            ts = env.step({"primitive": "move", "move": [float(forward), float(turn)]})
        self.write_model()


def main() -> int:
    with RemoteEnv() as env:
        Agent().run(env)
    return 0


if __name__ == "__main__":
    sys.exit(main())
