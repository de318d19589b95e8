"""What every track's audit and score notes share: findings, log steps against the host's
count, and the hook through which a track adds checks of its own.

A record of ``episode_log.jsonl`` names the host's step (the count of step requests served)
it is about, give or take ``STEP_SLACK``. ``log_step_findings`` is the one check of that:
``eagc audit`` reports it to organizers (``orchestrator/_episode/audit.py``), and the Track
1 score card notes it to the team (``plugins/track1/_score.py``).

A track's own checks are an ``EpisodeChecks`` (``TrackPlugin.audit`` makes a fresh one per
episode): ``eagc audit`` feeds it what the agent was shown as it reads the log and replays
it, then asks for its ``findings`` on an ``AuditInput``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict

from schemas import ActionResult, HostMessage, LogRecord
from simhost.host import HostEventModel, ScenarioRecord

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


@dataclass(frozen=True)
class Snapshot:
    """The agent's files at one moment: ``name`` (a stage, or ``final``) at host ``step``."""

    name: str
    step: int
    files: Mapping[str, bytes]


@dataclass(frozen=True)
class AuditInput:
    """What a track's checks read of one episode once its log is read (one object, so that
    fields can be added)."""

    scenario: ScenarioRecord
    """The hidden scenario as the log recorded it."""
    events: Sequence[HostEventModel]
    """The host's events (``/eagc/event``), in log order."""
    snapshots: Sequence[Snapshot]
    """The files at each stage end, then at the end (``final``), in time order."""
    log: Sequence[LogRecord]
    """The final ``episode_log.jsonl``'s records (empty when it is missing or refused)."""
    host: HostSteps


class EpisodeChecks(ABC):
    """A track's own checks of one episode (``TrackPlugin.audit``).

    ``eagc audit`` calls ``observe``, ``message`` and ``action`` with what the agent was
    shown, in order, as it reads the log (observation JSON, messages, action results, small
    tensors) and replays it (every tensor), then ``findings`` once."""

    def observe(self, step: int, data: Mapping[str, Any],  # noqa: B027 - optional
                tensors: Mapping[str, Any]) -> None:
        """One observation at host ``step``: its JSON entries and (any of) its tensors."""

    def message(self, step: int, message: HostMessage) -> None:  # noqa: B027 - optional
        """One host message (an instruction, queries, …)."""

    def action(self, step: int, action: Mapping[str, Any],  # noqa: B027 - optional
               result: ActionResult) -> None:
        """One action as the host checked it, and its result; ``step``: the one it made."""

    @abstractmethod
    def findings(self, episode: AuditInput) -> list[Finding]:
        """Everything the checks found."""
