"""The contract between the sim host and a track's live episode (implemented by plugins).

The host owns the protocol, the clock and the stages' order; a ``TrackEpisode`` owns the
world and its rules. The host calls, in order::

    reset() → on_stage_start(stage 0) → step()/answer()… → on_stage_end(stage 0, …)
    → on_stage_start(stage 1) → … → on_stage_end(last) → close()

Actions reach ``step`` already checked against ``action_spec`` (dtype, shape, bounds,
finite), as numpy arrays (or the index of a named choice).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from schemas import ActionResult, EndReason, FieldSpec, HostMessage

StageEnd = Literal["budget", "steps", "agent", "episode_over", "stopped"]


@dataclass(frozen=True)
class StageSpec:
    """A stage and its official budget (before the campaign's time scale)."""

    name: str
    budget_s: float
    max_steps: int | None = None
    allows_motion: bool = True
    description: str = ""


@dataclass(frozen=True)
class Pose:
    """A rigid pose in the world frame (metres; unit quaternion w, x, y, z).

    Organizer-only: the MCAP recorder logs a track's poses in a Foxglove schema, so that
    the 3D panel shows the robot's or the parts' trajectory."""

    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Observation:
    """What the agent sees: arrays travel as tensors, the rest as JSON."""

    tensors: Mapping[str, np.ndarray] = field(default_factory=dict)
    data: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class StepOutcome:
    """The result of one request handled by the episode.

    ``events`` are organizer-only records (exception triggered, subgoal reached, …) that go
    to the MCAP log and the scorer, never to the agent. ``end_reason`` (when
    ``episode_over``) is an ``EndReason``; its plain string value works too.
    """

    observation: Observation
    action: ActionResult | None = None
    messages: tuple[HostMessage, ...] = ()
    episode_over: bool = False
    end_reason: EndReason | None = None
    events: tuple[Mapping[str, Any], ...] = ()


class EpisodeOutcome(BaseModel):
    """What one episode achieved (organizer-only), as ``TrackEpisode.outcome`` returns it.

    A track subclasses it with what its scorer reads (progress, ground truth, events); the
    fields declared here are the ones the episode worker reads of every track."""

    model_config = ConfigDict(extra="forbid")

    sim_warnings: int = Field(0, description="MuJoCo warnings raised during the episode "
                              "(the result's ``stats.sim_warnings``).")


class TrackEpisode(ABC):
    """One live episode of a track: the world plus the track's rules for it."""

    #: Specs announced to the agent at hello.
    observation_spec: tuple[FieldSpec, ...]
    action_spec: tuple[FieldSpec, ...]

    @abstractmethod
    def reset(self) -> Observation:
        """Puts the world in its initial state and returns the first observation."""

    @abstractmethod
    def step(self, stage: str, action: Mapping[str, Any]) -> StepOutcome:
        """Applies one checked action during ``stage``."""

    def answer(self, stage: str, answers: Mapping[str, Any]) -> StepOutcome:
        """Takes the agent's answers to queries. Default: answers are not expected."""
        return StepOutcome(
            observation=self.observe(),
            action=ActionResult(applied=False, ok=False, reason="no queries in this track"),
        )

    def on_stage_start(self, stage: str) -> tuple[HostMessage, ...]:
        """Called when ``stage`` begins; returns messages for the agent (instruction, …)."""
        return ()

    def on_stage_end(
        self, stage: str, *, ended_by: StageEnd, payload: Mapping[str, Any]
    ) -> tuple[Mapping[str, Any], ...]:
        """Called when ``stage`` ends (``payload``: the agent's end_stage payload).

        Returns organizer-only events.
        """
        return ()

    @abstractmethod
    def observe(self) -> Observation:
        """The current observation, without changing anything."""

    def step_budget(self, stage: str) -> int | None:
        """This episode's own step cap for ``stage`` (e.g. derived from its ground truth, so
        that exhaustive search does not fit), or None. Known from construction: the host
        announces it at ``hello`` and enforces the smaller of it and any campaign-wide cap."""
        return None

    def poses(self) -> Mapping[str, Pose]:
        """Organizer-only poses (robot, parts) by frame name, for the MCAP 3D view."""
        return {}

    def sim_state(self) -> bytes:
        """The full simulator state, for replay. Default: none."""
        return b""

    def state_hash(self) -> str:
        """A short hash of the simulator state, logged every step."""
        return ""

    def outcome(self) -> EpisodeOutcome:
        """Organizer-only summary the track's scorer reads (ground truth, progress, events):
        the track's ``EpisodeOutcome`` subclass. Default: nothing but the base's fields."""
        return EpisodeOutcome()

    def close(self) -> None:  # noqa: B027 - optional hook
        """Releases the world's resources."""
