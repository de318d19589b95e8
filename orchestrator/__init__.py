"""Campaigns and episodes: container runtimes, the episode worker, images, the CLI.

Public API: ``run_episode``, ``EpisodeSpec``, ``DockerRuntime``, ``LocalProcessRuntime``,
``AgentRuntime``, ``AgentLaunch``, ``AgentHandle``, ``collect``; errors derive from
``OrchestratorError``; ``__version__`` is eagc's (``schemas.__version__``, from the installed
distribution). Names load on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "run_episode": "orchestrator._episode.worker",
    "EpisodeSpec": "orchestrator._episode.worker",
    "new_episode_id": "orchestrator._episode.worker",
    "DockerRuntime": "orchestrator._runtimes.docker",
    "LocalProcessRuntime": "orchestrator._runtimes.local",
    "AgentRuntime": "orchestrator._runtimes.interface",
    "AgentLaunch": "orchestrator._runtimes.interface",
    "AgentHandle": "orchestrator._runtimes.interface",
    "AgentStartError": "orchestrator._runtimes.interface",
    "InfraError": "orchestrator._runtimes.interface",
    "OrchestratorError": "orchestrator._errors",
    "UsageError": "orchestrator._errors",
    "collect": "orchestrator._episode.collect",
    "build_all": "orchestrator._images.build",
    "__version__": "schemas",
}

__all__ = [
    "AgentHandle",
    "AgentLaunch",
    "AgentRuntime",
    "AgentStartError",
    "DockerRuntime",
    "EpisodeSpec",
    "InfraError",
    "LocalProcessRuntime",
    "OrchestratorError",
    "UsageError",
    "build_all",
    "collect",
    "new_episode_id",
    "run_episode",
]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'orchestrator' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)
