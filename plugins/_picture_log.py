"""What a track's picture reads of an episode's MCAP log, and how it wraps its title.

``read_episode(mcap, pose_key)``: the scenario record, the robot's pose at each logged
observation (the observation tensor ``pose_key``: Track 1's ``odometry``, sanity's
``position``), the host's events (``simhost.host``'s record models, with their log times),
and the score (the ``/eagc/score`` record is the episode's ``EpisodeResult``; None when
the episode was never scored). A log without a scenario, or with a record that does not
read, raises ``McapRecordError`` (a ``ValueError``), in one line.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass, field
from pathlib import Path

from schemas import EpisodeResult
from simhost.host import (
    EpisodeEndEvent,
    HostEventModel,
    McapRecordError,
    ScenarioRecord,
    SmallTensors,
    StageStartEvent,
    read_records,
)


@dataclass
class EpisodeLog:
    scenario: ScenarioRecord
    poses: list[tuple[int, list[float]]] = field(default_factory=list)
    events: list[tuple[int, HostEventModel]] = field(default_factory=list)
    total: float | None = None

    def stage_starts(self) -> list[tuple[int, str]]:
        """(log time, stage) of each stage's start, in time order."""
        return sorted((t, e.stage) for t, e in self.events if isinstance(e, StageStartEvent))

    def end_reason(self) -> str:
        """Why the episode ended (``unfinished`` when the log does not say)."""
        return next((str(e.reason) for _, e in reversed(self.events)
                     if isinstance(e, EpisodeEndEvent)), "unfinished")


def read_episode(mcap: Path, pose_key: str) -> EpisodeLog:
    scenario: ScenarioRecord | None = None
    poses: list[tuple[int, list[float]]] = []
    events: list[tuple[int, HostEventModel]] = []
    total: float | None = None
    topics = ["/eagc/scenario", "/eagc/observation", "/eagc/event", "/eagc/score"]
    for record in read_records(mcap, topics):
        match record.body:
            case ScenarioRecord() as scenario:
                pass
            case SmallTensors() as tensors:
                pose = tensors.vector(pose_key)
                if pose is not None:
                    poses.append((record.log_time, pose))
            case EpisodeResult() as result:
                total = result.score.total
            case event if record.topic == "/eagc/event":
                events.append((record.log_time, event))
    if scenario is None:
        raise McapRecordError(f"{mcap}: no /eagc/scenario message: not an eagc episode log")
    return EpisodeLog(scenario, poses, events, total)


def title_lines(lines: list[str], width: int) -> list[str]:
    """``lines`` wrapped so that none runs past a picture ``width`` pixels wide (8 px a
    character, 8 px of margin each side); a word longer than a line is cut."""
    chars = max(8, (width - 16) // 8)
    return [part for line in lines
            for part in textwrap.wrap(line, chars, break_on_hyphens=False) or [""]]
