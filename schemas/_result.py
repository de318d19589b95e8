"""What one episode produced: its status, score card, statistics and failure report."""

from __future__ import annotations

from enum import StrEnum
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field


class EpisodeStatus(StrEnum):
    """How an episode ended. ``agent_*`` are final; ``infra_error`` may be retried."""

    COMPLETED = "completed"
    AGENT_TIMEOUT = "agent_timeout"
    AGENT_CRASH = "agent_crash"
    AGENT_OOM = "agent_oom"
    AGENT_PROTOCOL = "agent_protocol"
    AGENT_BAD_FILES = "agent_bad_files"
    AGENT_NO_START = "agent_no_start"
    INFRA_ERROR = "infra_error"

    @property
    def failure_kind(self) -> Literal["agent", "infra"] | None:
        if self is EpisodeStatus.COMPLETED:
            return None
        return "infra" if self is EpisodeStatus.INFRA_ERROR else "agent"


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class ContainerExit(_Frozen):
    """How the agent's process ended, from the engine's own state."""

    exit_code: int | None = None
    oom_killed: bool = False
    killed_by_host: bool = Field(default=False, description="The host stopped it at the end.")
    exited_early: bool = Field(default=False, description="It ended before the episode did.")
    peak_memory_bytes: int | None = None
    log_tail: str = Field(default="", description="The last lines the agent printed.")
    error: str | None = Field(default=None, description="Engine error, if it never started.")


class FileCheck(_Frozen):
    """One file collected from ``/output``."""

    name: str
    ok: bool
    size: int | None = None
    reason: str = ""


class FailureReport(_Frozen):
    """What a team needs to understand why its episode failed. No hidden details."""

    kind: Literal["agent", "infra"]
    status: EpisodeStatus
    stage_reached: str | None
    limit_hit: str | None = Field(
        default=None, description="e.g. 'memory 512 MiB', 'stage budget of explore'."
    )
    exit_code: int | None = None
    oom_killed: bool = False
    message: str
    log_tail: str = ""


class ScoreCard(_Frozen):
    """A track's score of one episode. Components and total are in [0, 1]."""

    track: str
    total: float = Field(ge=0.0, le=1.0)
    components: dict[str, float]
    weights: dict[str, float]
    metrics: dict[str, float] = Field(
        default_factory=dict, description="Leaderboard columns, e.g. task_success, recovery."
    )
    notes: tuple[str, ...] = ()


class EpisodeStats(_Frozen):
    steps: int = 0
    invalid_actions: int = 0
    protocol_errors: dict[str, int] = Field(default_factory=dict)
    latency_ms_median: float | None = Field(
        default=None, description="Reply-to-next-request time, the agent's decision latency."
    )
    latency_ms_p99: float | None = None
    peak_memory_bytes: int | None = None
    wall_s: float = 0.0
    stage_durations_s: dict[str, float] = Field(default_factory=dict)
    sim_warnings: int = 0


class EpisodeResult(_Frozen):
    """Everything the worker returns for one episode."""

    episode: str = Field(description="Opaque episode id (also the agent's).")
    track: str
    split: str
    image: str
    runtime: str
    status: EpisodeStatus
    score: ScoreCard
    stats: EpisodeStats
    files: tuple[FileCheck, ...] = ()
    stages_reached: tuple[str, ...] = ()
    failure: FailureReport | None = None
    container: ContainerExit | None = None
    episode_dir: str | None = Field(default=None, description="Organizer-side folder.")
    mcap: str | None = None
    started_at: float
    finished_at: float
