"""Track 1 structured world model baseline (paper Table IV, "Structured WM + replanning"):
``structured.StructuredPlanner`` in its container. numpy only, no learning framework.

The look-ahead planner it extends, its priors and the heuristic map planner's modules are
the Track 1 baselines' library, ``examples/track1_common`` (this image is built ``FROM`` its
image).
"""

from __future__ import annotations

import sys
from pathlib import Path

_LIBRARY = Path(__file__).resolve().parent.parent / "track1_common"
if _LIBRARY.is_dir():  # a checkout; in the image the library sits beside this file (/app)
    sys.path.insert(1, str(_LIBRARY))

from entry import main  # noqa: E402
from structured import StructuredPlanner  # noqa: E402

Agent = StructuredPlanner

if __name__ == "__main__":
    sys.exit(main(Agent))
