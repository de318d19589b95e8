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

    exit_code: int | None = Field(default=None, description="The process's exit code "
                                  "(None: it was still running or never started).")
    oom_killed: bool = Field(default=False, description="The kernel killed it for memory.")
    killed_by_host: bool = Field(default=False, description="The host stopped it at the end.")
    exited_early: bool = Field(default=False, description="It ended before the episode did.")
    peak_memory_bytes: int | None = Field(default=None, description="Its memory's peak, "
                                          "as the engine measured it.")
    log_tail: str = Field(default="", description="The last lines the agent printed.")
    error: str | None = Field(default=None, description="Engine error, if it never started.")


class FileCheck(_Frozen):
    """One file collected from ``/output``."""

    name: str = Field(description="The file's name under /output, e.g. world_model.json.")
    ok: bool = Field(description="It was there and read (lines left out are in reason).")
    size: int | None = Field(default=None, description="Bytes (None: not there).")
    reason: str = Field(default="", description="What was wrong with it, or what was left "
                        "out of it, on one line.")


class FailureReport(_Frozen):
    """What a team needs to understand why its episode failed. No hidden details."""

    kind: Literal["agent", "infra"] = Field(description="Whose failure: the agent's, or "
                                            "the infrastructure's (retried, not charged).")
    status: EpisodeStatus
    stage_reached: str | None = Field(description="The last stage the episode entered.")
    limit_hit: str | None = Field(
        default=None, description="e.g. 'memory 512 MiB', 'stage budget of explore'."
    )
    exit_code: int | None = None
    oom_killed: bool = False
    message: str = Field(description="What went wrong, on one line.")
    log_tail: str = Field(default="", description="The last lines the agent printed.")


class ScoreCard(_Frozen):
    """A track's score of one episode. Components and total are in [0, 1]."""

    track: str
    total: float = Field(ge=0.0, le=1.0, description="The episode's score, 0-1 (the "
                         "leaderboard shows it x 100): the weighted sum of components.")
    components: dict[str, float] = Field(description="Each part of the score, 0-1, by the "
                                         "track's names (e.g. exploration, task).")
    weights: dict[str, float] = Field(description="Each component's weight in total.")
    metrics: dict[str, float] = Field(
        default_factory=dict, description="Leaderboard columns, e.g. task_success, recovery."
    )
    notes: tuple[str, ...] = Field(default=(), description="Where points were lost and "
                                   "why, one sentence each.")


class EpisodeStats(_Frozen):
    """How the episode ran, as the host counted it."""

    steps: int = Field(default=0, description="Actions the host applied (every stage).")
    invalid_actions: int = Field(default=0, description="Actions refused, malformed or "
                                 "failed (the action's ok was false).")
    protocol_errors: dict[str, int] = Field(default_factory=dict, description="Error "
                                            "replies by code (PROTOCOL.md's error codes).")
    latency_ms_median: float | None = Field(
        default=None, description="Reply-to-next-request time, the agent's decision latency."
    )
    latency_ms_p99: float | None = Field(default=None, description="The same, 99th "
                                         "percentile.")
    peak_memory_bytes: int | None = Field(default=None, description="The agent's memory "
                                          "peak.")
    wall_s: float = Field(default=0.0, description="Wall-clock seconds of the episode.")
    stage_durations_s: dict[str, float] = Field(default_factory=dict, description="Wall-"
                                                "clock seconds spent in each stage.")
    sim_warnings: int = Field(default=0, description="The simulator's warnings (e.g. "
                              "contacts it could not resolve); not the agent's doing.")


class EpisodeResult(_Frozen):
    """Everything the worker returns for one episode."""

    episode: str = Field(description="Opaque episode id (also the agent's).")
    track: str = Field(description="The track (sanity, track1, track2).")
    split: str = Field(description="The split played (standard, challenge; dev and the "
                       "tracks' public extra splits, e.g. vision).")
    image: str = Field(description="The agent's image (or command, for --runtime local).")
    runtime: str = Field(description="docker, or local (development only, no sandbox).")
    status: EpisodeStatus = Field(description="How it ended: completed, or why not.")
    score: ScoreCard
    stats: EpisodeStats
    files: tuple[FileCheck, ...] = Field(default=(), description="Each file collected "
                                         "from /output and how it read.")
    stages_reached: tuple[str, ...] = Field(default=(), description="The stages entered, "
                                            "in order.")
    failure: FailureReport | None = Field(default=None, description="Why it did not "
                                          "complete (None when it did).")
    container: ContainerExit | None = None
    episode_dir: str | None = Field(default=None, description="Organizer-side folder.")
    mcap: str | None = Field(default=None, description="The episode's MCAP log.")
    started_at: float = Field(description="Unix time, seconds.")
    finished_at: float = Field(description="Unix time, seconds.")
