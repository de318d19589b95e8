"""Waits 0.1 s before every step (standing still) until the episode ends.

Its episodes last (step cap per stage × stages × 0.1 s): the benchmark sets the cap to get
episodes of a chosen length that cost almost no CPU.
"""

import time

from simhost.client import RemoteEnv

STEP_S = 0.1

with RemoteEnv() as env:
    env.hello(agent="waiting")
    ts = env.reset()
    while not ts.episode_over:
        time.sleep(STEP_S)
        ts = env.step({"velocity": [0.0, 0.0]})
print(f"episode over: {ts.end_reason}", flush=True)
