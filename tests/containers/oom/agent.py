"""Says hello, then allocates far more memory than its limit."""

from simhost.client import RemoteEnv

env = RemoteEnv()
env.hello(agent="oom")
env.reset()
hog = []
while True:
    hog.append(bytearray(16 << 20))
    hog[-1][::4096] = b"x" * len(hog[-1][::4096])
