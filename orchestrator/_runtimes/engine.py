"""The Docker engine: one client, whether one answers at all, and eagc's containers.

Below the runtime (``docker``), the reaper (``reaper``) and ``cleanup``, which each need a
client and race each other (and the episode watcher) to remove containers.
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


def managed_containers(client: Any, labels: list[str]) -> list[Any]:
    """Every container (running or not) carrying all of ``labels`` (``key=value``).

    The engine lists ids, then the SDK inspects each: a container another process removes
    in between (a watcher, a reaper on another node, ``eagc cleanup``) is left out instead
    of raising ``NotFound``.
    """
    return client.containers.list(all=True, filters={"label": labels}, ignore_removed=True)


def docker_answers() -> bool:
    """Whether a Docker engine answers here (the demo picks its runtime by it)."""
    try:
        docker_client()
    except InfraError:
        return False
    return True
