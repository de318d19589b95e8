"""The entry point of the Track 1 baselines' images: one agent plays the episode the sim
host serves (``RemoteEnv``), and the process exits 0."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from simhost.client import RemoteEnv


class Player(Protocol):
    """What a baseline's agent offers: it plays a whole episode."""

    def run(self, env: RemoteEnv) -> None: ...


def main(agent: Callable[[], Player]) -> int:
    with RemoteEnv() as env:
        agent().run(env)
    return 0
