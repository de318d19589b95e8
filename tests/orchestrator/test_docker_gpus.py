"""``Limits.gpus`` becomes Docker's device request, as the engine records it.

No GPU here: the container is created by the real engine with the options an episode's
would have (``DockerRuntime.container_options``), never started (starting it needs the
NVIDIA runtime), and its ``HostConfig`` read back from the engine."""

from __future__ import annotations

import secrets
from pathlib import Path
from typing import Any

import pytest

from orchestrator._runtimes.docker import DockerRuntime
from orchestrator._runtimes.interface import AgentLaunch
from schemas import Limits

pytestmark = [pytest.mark.docker]


def _host_config(engine: Any, image: str, tmp_path: Path, limits: Limits) -> dict[str, Any]:
    launch = AgentLaunch(image=image, episode=f"gpu-test-{secrets.token_hex(4)}",
                         socket_dir=tmp_path, output_dir=tmp_path, limits=limits)
    c = engine.containers.create(image, **DockerRuntime(engine).container_options(launch))
    try:
        c.reload()
        return dict(c.attrs["HostConfig"])
    finally:
        c.remove(force=True)


def test_granted_gpus_become_the_containers_device_request(
        docker_engine: Any, images: dict[str, str], tmp_path: Path) -> None:
    image = images["eagc/base:bookworm"]
    granted = _host_config(docker_engine, image, tmp_path, Limits(gpus=("0", "2")))
    [request] = granted["DeviceRequests"]
    assert request["DeviceIDs"] == ["0", "2"]
    assert request["Capabilities"] == [["gpu"]]
    assert request["Count"] == 0  # exactly those devices, not "any N"
    # The sandbox holds with a GPU too.
    assert granted["NetworkMode"] == "none" and granted["ReadonlyRootfs"]
    assert granted["CapDrop"] == ["ALL"]
    none = _host_config(docker_engine, image, tmp_path, Limits())
    assert not none["DeviceRequests"]
