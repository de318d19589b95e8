"""Plays a few steps, then crashes with exit code 3."""

import sys

from simhost.client import RemoteEnv

env = RemoteEnv()
env.hello(agent="crash")
ts = env.reset()
for _ in range(5):
    ts = env.step({"velocity": [0.2, 0.1]})
print("about to crash on purpose", flush=True)
sys.exit(3)
