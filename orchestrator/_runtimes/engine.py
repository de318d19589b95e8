"""The Docker engine: one client, and whether one answers at all.

Below both the runtime (``_docker``) and the reaper (``_reaper``), which each need a client.
"""

from __future__ import annotations

from typing import Any

from orchestrator._runtimes.interface import InfraError


def docker_client() -> Any:
    """A docker SDK client, or InfraError saying how to get an engine."""
    import docker

    try:
        client = docker.from_env(timeout=120)
        client.ping()
    except Exception as e:  # noqa: BLE001
        raise InfraError(
            f"no Docker engine answers ({e}). Start one (`dockerd &` as root, or "
            "`systemctl start docker`), or use --runtime local for development."
        ) from e
    return client


def docker_answers() -> bool:
    """Whether a Docker engine answers here (the demo picks its runtime by it)."""
    try:
        docker_client()
    except InfraError:
        return False
    return True
