"""The toy track's agent (``_toy_track.py``): walk forward until the goal is in sight, say
where it is, then drive onto it."""

from __future__ import annotations

import numpy as np

from simhost.client import OutputFiles, RemoteEnv


def main() -> None:
    env, files = RemoteEnv(), OutputFiles()
    env.hello(agent="eagc-toy/1")
    ts, step, said = env.reset(), 0, False
    while not ts.episode_over:
        obs = ts.observation
        if obs["goal_visible"][0] > 0.5:
            offset = float(obs["goal_offset"][0])
            if not said:
                goal = float(obs["position"][0]) + offset
                files.log(step=step, stage=ts.stage, event="model_update", data={"goal": goal})
                said = True
            move = np.clip(offset / 0.5, -1.0, 1.0)
        else:
            move = 1.0
        ts = env.step({"move": np.array([move], np.float32)})
        step += 1
    files.log(step=step, stage=ts.stage, event="stage", data={"done": True})
    files.close()
    env.close()


if __name__ == "__main__":
    main()
