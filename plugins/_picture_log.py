"""What a track's picture reads of an episode's MCAP log, and how it wraps its title.

``read_episode(mcap, pose_key)``: the scenario record, the robot's pose at each logged
observation (the observation field ``pose_key``: Track 1's ``odometry``, sanity's
``position``), the host's events, and the score (the ``/eagc/score`` record is the
episode's ``EpisodeResult``; None when the episode was never scored).
"""

from __future__ import annotations

import json
import textwrap
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from schemas import EpisodeResult


@dataclass
class EpisodeLog:
    scenario: dict[str, Any] = field(default_factory=dict)
    poses: list[tuple[int, list[float]]] = field(default_factory=list)
    events: list[tuple[int, dict[str, Any]]] = field(default_factory=list)
    total: float | None = None


def read_episode(mcap: Path, pose_key: str) -> EpisodeLog:
    from mcap.reader import make_reader

    out = EpisodeLog()
    with mcap.open("rb") as f:
        for _, channel, message in make_reader(f).iter_messages(
                topics=["/eagc/scenario", "/eagc/observation", "/eagc/event", "/eagc/score"]):
            doc = json.loads(message.data)
            if channel.topic == "/eagc/scenario":
                out.scenario = doc
            elif channel.topic == "/eagc/observation" and pose_key in doc:
                out.poses.append((message.log_time, doc[pose_key]))
            elif channel.topic == "/eagc/event":
                out.events.append((message.log_time, doc))
            elif channel.topic == "/eagc/score":
                out.total = EpisodeResult.model_validate(doc).score.total
    return out


def title_lines(lines: list[str], width: int) -> list[str]:
    """``lines`` wrapped so that none runs past a picture ``width`` pixels wide (8 px a
    character, 8 px of margin each side); a word longer than a line is cut."""
    chars = max(8, (width - 16) // 8)
    return [part for line in lines
            for part in textwrap.wrap(line, chars, break_on_hyphens=False) or [""]]
