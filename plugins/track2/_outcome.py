"""What one Track 2 episode achieved (organizer-only): the typed outcome the scorer reads.

``Track2Episode.outcome()`` returns a ``Track2Outcome``; ``Track2.score`` reads it. Progress
is the bench's ``(stage index + fraction) / stages`` (1 on success); ``start_progress`` is
where an attempt began, so that what an agent achieved is measured from the start state, not
from zero.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from simhost.host import EpisodeOutcome


class AttemptRecord(BaseModel):
    """One attempt on the hidden instance."""

    model_config = ConfigDict(extra="forbid")

    index: int = Field(ge=1, description="1-based.")
    steps: int = 0
    success: bool = False
    start_progress: float = 0.0
    peak_progress: float = 0.0
    final_progress: float = 0.0
    final_value: float | None = Field(default=None, description="The goal's magnitude at the "
                                      "end (turn, fraction, depth, ...), as ``BenchInfo.value``.")
    ended_by: str = ""
    wall_s: float = 0.0
    sim_s: float = 0.0

    @property
    def gain(self) -> float:
        """Progress made from the start state, as a fraction of what was left (1 on success)."""
        if self.success:
            return 1.0
        left = 1.0 - self.start_progress
        if left <= 1e-9:
            return 0.0
        return min(1.0, max(0.0, (self.peak_progress - self.start_progress) / left))


class Track2Outcome(EpisodeOutcome):
    """The episode's attempts, timings and stability counts (``sim_warnings``: MuJoCo
    warnings over the execution's steps)."""

    model_config = ConfigDict(extra="forbid")

    family: str = ""
    distance: float = 0.0
    attempts: list[AttemptRecord] = Field(default_factory=list)
    max_attempts: int = 3
    attempt_steps: int = 0
    success: bool = False
    success_attempt: int | None = None
    stage_durations_s: dict[str, float] = Field(default_factory=dict)
    adapt_time_s: float = Field(0.0, description="Reception and parsing, plus the execution "
                                "time not spent stepping the simulator (s).")
    max_contact_force: float = 0.0
    steps: int = 0
    excess_force_steps: int = 0
    drops: int = 0
    limit_steps: int = 0
    jerk_steps: int = 0
    env_invalid: int = 0
    refused: int = 0

    @property
    def gain(self) -> float:
        """The best progress any attempt made from its start state (1 on success)."""
        return max((a.gain for a in self.attempts if a.steps > 0), default=0.0)

    @property
    def attempts_needed(self) -> int:
        """The attempt that succeeded, or all the attempts allowed (a failure needs them all)."""
        return int(self.success_attempt or self.max_attempts)
