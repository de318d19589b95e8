"""Sanity baseline agent: what a team copies to start. Uses only simhost.client (light).

Explores the arena along a lawn-mower path until the target is in sensing range, writes its
position to /output/world_model.json and ends the stage; then drives to it. If the target
jumps (the track's controlled exception), it logs ``exception_detected``, updates its model
and drives to the new place. Files go through ``OutputFiles`` (checked against the schema,
written to a temporary name and renamed, so the host never sees half a file).
"""

from __future__ import annotations

import sys

import numpy as np

from schemas import WORLD_MODEL_VERSION, WorldModel
from simhost.client import OutputFiles, RemoteEnv

WAYPOINTS = [(-1.5, -1.5), (1.5, -1.5), (1.5, -0.5), (-1.5, -0.5), (-1.5, 0.5), (1.5, 0.5),
             (1.5, 1.5), (-1.5, 1.5)]


class Agent:
    def __init__(self) -> None:
        self.step = 0
        self.target: np.ndarray | None = None
        self.files = OutputFiles()  # $EAGC_OUTPUT

    def record(self, event: str, stage: str, **kw: object) -> None:
        self.files.log(step=self.step, stage=stage, event=event, **kw)

    def write_model(self) -> None:
        objects = [] if self.target is None else [
            {"id": "target", "category": "target", "position": self.target.tolist()}]
        self.files.write(WorldModel(version=WORLD_MODEL_VERSION, step=self.step,
                                    rooms=[{"id": "arena"}], objects=objects))

    def sense(self, obs: dict) -> bool:
        """Updates the target estimate; True when the target is not where the model says."""
        pos = obs["position"].astype(float)
        if obs["target_visible"][0] > 0.5:
            seen = pos + obs["target_rel"].astype(float)
            moved = self.target is not None and np.linalg.norm(seen - self.target) > 0.3
            self.target = seen
            return moved
        # The model says the target is right here, but it is not in sight: it moved.
        if self.target is not None and np.linalg.norm(self.target - pos) < 0.8:
            self.target = None
            return True
        return False

    def run(self, env: RemoteEnv) -> None:
        env.hello(agent="eagc-sanity-baseline/1")
        ts = env.reset()
        wp = 0
        while not ts.episode_over:
            obs = ts.observation
            moved = self.sense(obs)
            if ts.stage == "explore":
                if self.target is not None:
                    self.record("model_update", ts.stage, data={"target": self.target.tolist()})
                    self.write_model()
                    ts = env.end_stage()
                    continue
                goal = np.array(WAYPOINTS[wp % len(WAYPOINTS)])
                if np.linalg.norm(goal - obs["position"]) < 0.15:
                    wp += 1
            else:
                if moved:
                    self.record("exception_detected", ts.stage, exception_type="target_moved")
                    self.write_model()
                if self.target is None:  # search again
                    goal = np.array(WAYPOINTS[wp % len(WAYPOINTS)])
                    if np.linalg.norm(goal - obs["position"]) < 0.15:
                        wp += 1
                else:
                    goal = self.target
                    if moved:
                        self.record("model_update", ts.stage, data={"target": goal.tolist()})
            velocity = np.clip((goal - obs["position"]) * 3.0, -1.0, 1.0)
            self.step += 1
            ts = env.step({"velocity": velocity.astype(np.float32).tolist()})
        self.write_model()
        self.record("note", ts.stage, data={"end": ts.end_reason})


def main() -> int:
    with RemoteEnv() as env:
        Agent().run(env)
    return 0


if __name__ == "__main__":
    sys.exit(main())
