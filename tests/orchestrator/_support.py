"""Helpers shared by the Docker tests (not collected: no ``test_`` prefix)."""

from __future__ import annotations

from typing import Any

from orchestrator._runtimes.docker import DockerRuntime
from orchestrator._runtimes.interface import AgentHandle, AgentLaunch


class RecordingRuntime(DockerRuntime):
    """The real DockerRuntime, also keeping what the engine says about each container."""

    def __init__(self, client: Any) -> None:
        super().__init__(client)
        self.inspected: list[dict[str, Any]] = []

    def start(self, launch: AgentLaunch) -> AgentHandle:
        handle = super().start(launch)
        handle.container.reload()  # type: ignore[attr-defined]
        self.inspected.append(handle.container.attrs)  # type: ignore[attr-defined]
        return handle
