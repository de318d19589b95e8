"""What every track's audit and score notes share: findings, and log steps against the
host's count.

A record of ``episode_log.jsonl`` names the host's step (the count of step requests served)
it is about, give or take ``STEP_SLACK``. ``log_step_findings`` is the one check of that:
``eagc audit`` reports it to organizers (``orchestrator/_episode/audit.py``), and the Track
1 score card notes it to the team (``plugins/track1/_score.py``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

from pydantic import BaseModel, ConfigDict

from schemas import LogRecord

#: A record may name the step it is about to make, or the one it just made.
STEP_SLACK = 1
Severity = Literal["flag", "warning", "note"]


class Finding(BaseModel):
    """One finding: which check, how serious (``flag``: a sign of something wrong;
    ``warning``: worth a look; ``note``: for the record), where, and why."""

    model_config = ConfigDict(frozen=True)

    check: str
    severity: Severity
    message: str
    step: int | None = None
    subjects: tuple[str, ...] = ()
    """What it is about (ids, rooms, an exception type), when it is about something."""


@dataclass(frozen=True)
class HostSteps:
    """The host's step count: in total, and where each stage began and ended."""

    total: int
    stages: Mapping[str, tuple[int, int]] = field(default_factory=dict)
    """Stage → (steps served when it started, steps served when it ended)."""

    def at_end(self, stage: str) -> int:
        return self.stages.get(stage, (self.total, self.total))[1]


def log_step_findings(records: Sequence[LogRecord], host: HostSteps,
                      *, where: str = "episode_log.jsonl") -> list[Finding]:
    """Each record's ``step`` against the host's count (module doc); pure. A step past
    the host's total is a flag; one outside the stage the record names, a warning."""
    out: list[Finding] = []
    past = [r for r in records if r.step > host.total + STEP_SLACK]
    if past:
        r = past[0]
        out.append(Finding(check="log_steps", severity="flag", step=r.step, message=(
            f"{where}: {len(past)} record(s) name a step past the {host.total} the host "
            f"served (first: step {r.step}, {r.event})")))
    outside = [r for r in records if r.stage in host.stages and r not in past
               and not (host.stages[r.stage][0] - STEP_SLACK <= r.step
                        <= host.stages[r.stage][1] + STEP_SLACK)]
    if outside:
        r = outside[0]
        lo, hi = host.stages[r.stage]  # type: ignore[index]
        out.append(Finding(check="log_steps", severity="warning", step=r.step, message=(
            f"{where}: {len(outside)} record(s) name a step outside their stage (first: "
            f"step {r.step}, {r.event} in {r.stage!r}, which ran over host steps "
            f"{lo}-{hi})")))
    return out
