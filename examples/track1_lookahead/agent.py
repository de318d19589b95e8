"""Track 1 look-ahead baseline (paper Table IV, "PathDreamer-style planner"):
``lookahead.LookaheadPlanner`` in its container, with the priors it learned offline
(``priors.npz``, from ``train_priors.py``). numpy only, no learning framework.

The planner, its priors and the heuristic map planner's modules it builds on are the Track 1
baselines' library, ``examples/track1_common`` (this image is built ``FROM`` its image).
"""

from __future__ import annotations

import sys
from pathlib import Path

_LIBRARY = Path(__file__).resolve().parent.parent / "track1_common"
if _LIBRARY.is_dir():  # a checkout; in the image the library sits beside this file (/app)
    sys.path.insert(1, str(_LIBRARY))

from entry import main  # noqa: E402
from lookahead import LookaheadPlanner  # noqa: E402

Agent = LookaheadPlanner

if __name__ == "__main__":
    sys.exit(main(Agent))
