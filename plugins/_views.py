"""What a track shows of a recorded episode on the viewer's pages (``eagc report``).

The viewer reads what every track records (stages, events, frames, the robot's path,
snapshots, the score card) by itself and asks the track for the rest through three hooks
of ``TrackPlugin``, each given a ``RecordedEpisode``: ``episode_map`` (the picture its path
is drawn over), ``step_pictures`` (pictures of spans of steps) and ``truth`` (organizers
only: the agent's model against the hidden truth). A hook's defaults show nothing.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simhost.host import ScenarioRecord


@dataclass(frozen=True)
class RecordedEpisode:
    """One recorded episode, as the viewer hands it to a track's hooks."""

    folder: Path
    """The episode folder (``<runs>/<episode>``: ``host/episode.mcap``,
    ``host/snapshots/<stage>/``, ``host/output/``, ``input/``)."""
    scenario: ScenarioRecord
    """The hidden scenario as the episode's log recorded it."""
    organizer: bool = False
    """The organizer's view, which may show the hidden scenario; False: a team's view,
    which must show nothing of it."""
    public_seed: bool = False
    """The episode's seed is public (a local test, a public split): its scenario is then
    no secret, and a team's view may show its layout."""


@dataclass(frozen=True, eq=False)
class EpisodeMap:
    """The picture the viewer draws the robot's path over: the world from above, a point
    (x, y) of the world at pixel (``ox + x * scale``, ``oy - y * scale``)."""

    rgb: np.ndarray
    """H×W×3 uint8."""
    ox: float
    oy: float
    scale: float
    """Pixels per metre."""
    caption: str
    """What the picture is (e.g. ``the house from above``)."""


@dataclass(frozen=True)
class StepPicture:
    """A picture of a span of steps, shown while the scrubber is in it (Track 2: an
    attempt beside the demonstration)."""

    first_step: int
    last_step: int
    caption: str
    png: bytes


@dataclass(frozen=True)
class TruthReport:
    """Organizers only: the agent's model against the hidden truth, a line per difference."""

    of: str
    """What was compared (e.g. ``exploration · world_model.json``)."""
    lines: tuple[str, ...]
    note: str = ""
    """How to read the lines (what the truth is, where it may differ from the score's)."""
