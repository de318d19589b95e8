"""Track 1 structured world model baseline (paper Table IV, "Structured WM + replanning"):
``structured.StructuredPlanner`` in its container. numpy only, no learning framework.

``planner.py``, ``mapping.py``, ``skills.py``, ``model.py`` and ``parsing.py`` are the
heuristic map planner's, ``lookahead.py``, ``priors.py`` and ``priors.npz`` the look-ahead
planner's, copied unchanged (each example folder builds on its own).
"""

from __future__ import annotations

import sys

from structured import StructuredPlanner

from simhost.agent import RemoteEnv

Agent = StructuredPlanner


def main() -> int:
    with RemoteEnv() as env:
        Agent().run(env)
    return 0


if __name__ == "__main__":
    sys.exit(main())
