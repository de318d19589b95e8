"""Resets, then never sends another request (a frozen agent)."""

import time

from simhost.client import RemoteEnv

env = RemoteEnv()
env.hello(agent="frozen")
env.reset()
while True:
    time.sleep(3600)
