"""Track 1 heuristic map planner baseline (paper Table IV): ``planner.MapPlanner`` in its
container. Uses only ``simhost.agent`` (``RemoteEnv``, ``OutputFiles``), numpy and the
standard library.
"""

from __future__ import annotations

import sys

from planner import MapPlanner

from simhost.agent import RemoteEnv

Agent = MapPlanner


def main() -> int:
    with RemoteEnv() as env:
        Agent().run(env)
    return 0


if __name__ == "__main__":
    sys.exit(main())
