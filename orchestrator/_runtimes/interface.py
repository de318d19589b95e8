"""The container runtime interface: how an agent is started, watched and stopped.

``DockerRuntime`` is the only runtime for official runs. ``LocalProcessRuntime`` runs the
agent as a plain process for development, without a sandbox, and says so loudly.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from orchestrator._errors import OrchestratorError
from schemas import CONTAINER, ContainerExit, Limits

LABEL_PREFIX = "eagc"


def sample_interval(elapsed_s: float) -> float:
    """How long to wait before the next peak-memory sample of an agent running this long:
    dense at first, because a quick agent may be gone within a second."""
    return 0.05 if elapsed_s < 2.0 else 0.2


class RuntimeErrorBase(OrchestratorError, RuntimeError):
    """Raised when a container runtime fails (root of AgentStartError and InfraError)."""


class AgentStartError(RuntimeErrorBase):
    """Raised when the agent's image cannot be started for a reason of its own (agent failure):
    the image is missing, its command does not exist, …"""


class InfraError(RuntimeErrorBase):
    """Raised when the engine or the host failed (infrastructure failure, retried)."""


@dataclass(frozen=True)
class AgentLaunch:
    """Everything needed to start one agent for one episode."""

    image: str
    episode: str
    socket_dir: Path
    output_dir: Path
    limits: Limits
    input_dir: Path | None = None
    labels: Mapping[str, str] = field(default_factory=dict)
    #: The cores the agent runs on ("1,2"), apart from its sim host's; None: anywhere.
    cpuset: str | None = None
    #: The episode's heartbeat file (``orchestrator._runtimes.reaper``): named by the agent's label
    #: so that a reaper can tell a dead episode's agent from a live one.
    heartbeat: Path | None = None
    #: Hard deadline, seconds after the start: the runtime ends the agent then, from outside,
    #: whatever happened to the worker (the sum of the stage budgets, startup and grace).
    deadline_s: float | None = None

    def environment(
        self, *, socket_dir: str, output_dir: str, input_dir: str | None
    ) -> dict[str, str]:
        """The agent's environment (``CONTAINER.environment``). Nothing else."""
        return CONTAINER.environment(
            self.episode, socket_dir=socket_dir, output_dir=output_dir, input_dir=input_dir)


class AgentHandle(ABC):
    """A started agent."""

    id: str

    @abstractmethod
    def wait(self, timeout: float | None) -> bool:
        """Waits until the agent exits; True if it has."""

    def checkpoint(self) -> None:
        """Reads what can only be read while the agent runs (its peak memory). The worker
        calls it when the episode ends, before it gives the agent time to leave."""
        return None  # a runtime with nothing to read

    @abstractmethod
    def stop(self) -> ContainerExit:
        """Kills whatever still runs, reads how it ended and releases everything.

        Idempotent: later calls return the same ``ContainerExit``.
        """


class AgentRuntime(ABC):
    """Starts agents."""

    #: Name shown in results.
    name: str
    #: Only official runtimes may be used in a non-local campaign.
    official: bool

    @abstractmethod
    def start(self, launch: AgentLaunch) -> AgentHandle:
        """Starts the agent. Raises AgentStartError (agent failure) or InfraError."""

    def cleanup(self, labels: Mapping[str, str] | None = None) -> list[str]:
        """Removes agents left behind by a dead worker; returns what it removed."""
        return []
