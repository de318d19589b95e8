"""Track 1 random/scripted sanity baseline: checks submission, logging and scoring, nothing more.

Exploration: a few dozen random primitives (mostly moves; now and then one on a random
visible id), then a minimal ``world_model.json`` (the rooms whose signs it read and what it
sees last) and an end of stage. Planning: no answers, no plan. Execution: random
primitives, then ``done``. Uses only ``simhost.client`` (``RemoteEnv``, ``OutputFiles``),
numpy and the standard library.
"""

from __future__ import annotations

import sys

import numpy as np

from simhost.client import OutputFiles, RemoteEnv

STEPS = {"exploration": 40, "execution": 60}


class Agent:
    def __init__(self, seed: int = 0) -> None:
        self.rng = np.random.default_rng(seed)
        self.step = 0
        self.rooms: dict[int, str] = {}
        self.room: int | None = None
        self.counts: dict[str, int] = {}
        self.files = OutputFiles()

    def record(self, event: str, stage: str, **data: object) -> None:
        self.files.log(step=self.step, stage=stage, event=event, data=data)

    def action(self, obs: dict) -> dict:
        seen = [d["id"] for d in obs["detections"]]
        if self.rng.random() < 0.7 or not seen:
            turn, forward = self.rng.uniform(-1, 1), self.rng.uniform(0, 1)
            return {"primitive": "move", "move": [float(forward), float(turn)]}
        primitive = str(self.rng.choice(["open", "close", "pick", "place", "noop"]))
        return {"primitive": primitive, "target": int(self.rng.choice(seen))}

    def write_model(self, obs: dict) -> None:
        x, y, yaw = (float(v) for v in obs["odometry"])
        c, s = float(np.cos(yaw)), float(np.sin(yaw))
        objects = []
        for d in obs["detections"]:
            if d["kind"] in ("object", "tool"):
                dx, dy = d["rel_pos"]
                objects.append({"id": d["id"], "category": d["category"],
                                "colour": d["colour"], "room": self.room,
                                "position": [x + c * dx - s * dy, y + s * dx + c * dy]})
        self.files.write({
            "version": "eagc-world-model/v1", "step": self.step,
            "rooms": [{"id": r, "type": t} for r, t in self.rooms.items()],
            "objects": objects}, "world_model.json")

    def run(self, env: RemoteEnv) -> None:
        env.hello(agent="eagc-track1-sanity/1")
        ts = env.reset()
        self.record("stage", ts.stage)
        while not ts.episode_over:
            obs = ts.observation
            if int(obs["room"][0]) >= 0:  # a sign, read on entering a room
                self.room = int(obs["room"][0])
                self.rooms[self.room] = obs["room_name"]
            if ts.stage == "planning":
                ts = env.end_stage({})
                continue
            left = STEPS.get(ts.stage, 0) - self.counts.get(ts.stage, 0)
            if left <= 0 or (ts.steps_left is not None and ts.steps_left <= 1):
                if ts.stage == "exploration":
                    self.write_model(obs)
                    ts = env.end_stage()
                else:
                    ts = env.step({"primitive": "done"})
                continue
            self.step += 1
            self.counts[ts.stage] = self.counts.get(ts.stage, 0) + 1
            ts = env.step(self.action(obs))
        self.write_model(ts.observation)
        self.record("note", ts.stage, end=ts.end_reason)


def main() -> int:
    with RemoteEnv() as env:
        Agent().run(env)
    return 0


if __name__ == "__main__":
    sys.exit(main())
