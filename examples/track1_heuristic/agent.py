"""Track 1 heuristic map planner baseline (paper Table IV): ``planner.MapPlanner`` in its
container. Uses only ``simhost.client`` (``RemoteEnv``, ``OutputFiles``), numpy and the
standard library. The planner and its modules are the Track 1 baselines' library,
``examples/track1_common`` (this image is built ``FROM`` its image).
"""

from __future__ import annotations

import sys
from pathlib import Path

_LIBRARY = Path(__file__).resolve().parent.parent / "track1_common"
if _LIBRARY.is_dir():  # a checkout; in the image the library sits beside this file (/app)
    sys.path.insert(1, str(_LIBRARY))

from entry import main  # noqa: E402
from planner import MapPlanner  # noqa: E402

Agent = MapPlanner

if __name__ == "__main__":
    sys.exit(main(Agent))
