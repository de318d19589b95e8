"""Track 1 learned-vision baseline, for the ``vision`` split: the structured world model
planner (``examples/track1_structured``) on what a learned detector finds in the camera's
frames (``detector.py``, weights ``detector.npz`` trained by ``train_detector.py``), its
ids its own and its actions by pixel (``seeing.SeeingEnv``). numpy only.

This image is built ``FROM`` the structured planner's (``eagc/track1-structured``), which
holds the planner and the Track 1 baselines' library in /app.
"""

from __future__ import annotations

import sys
from pathlib import Path

_HERE = Path(__file__).resolve().parent
for _library in (_HERE.parent / "track1_structured", _HERE.parent / "track1_common"):
    if _library.is_dir():  # a checkout; in the image they sit beside this file (/app)
        sys.path.insert(1, str(_library))

from entry import main  # noqa: E402
from seeing import SeeingEnv  # noqa: E402
from structured import StructuredPlanner  # noqa: E402

from simhost.client import RemoteEnv  # noqa: E402


class VisionPlanner(StructuredPlanner):
    """The structured planner, seeing through the learned detector."""

    name = "eagc-track1-vision/1"

    def run(self, env: RemoteEnv) -> None:  # type: ignore[override]
        super().run(SeeingEnv(env))  # type: ignore[arg-type]


Agent = VisionPlanner

if __name__ == "__main__":
    sys.exit(main(Agent))
