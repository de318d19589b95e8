"""Track 1 look-ahead baseline (paper Table IV, "PathDreamer-style planner"):
``lookahead.LookaheadPlanner`` in its container, with the priors it learned offline
(``priors.npz``, from ``train_priors.py``). numpy only, no learning framework.

The modules ``planner.py``, ``mapping.py``, ``skills.py``, ``model.py`` and ``parsing.py``
are the heuristic map planner's, copied unchanged (each example folder builds on its own).
"""

from __future__ import annotations

import sys

from lookahead import LookaheadPlanner

from simhost.agent import RemoteEnv

Agent = LookaheadPlanner


def main() -> int:
    with RemoteEnv() as env:
        Agent().run(env)
    return 0


if __name__ == "__main__":
    sys.exit(main())
