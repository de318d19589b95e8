"""Docker fixtures: a real engine and real images built offline (never skipped in CI)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest

CONTAINERS = Path(__file__).resolve().parents[1] / "containers"
TEST_IMAGES = ["probe", "oom", "crash", "frozen", "silent", "bad_files"]


@pytest.fixture(scope="session")
def docker_engine() -> Any:
    from orchestrator._runtimes.docker import docker_client
    from orchestrator._runtimes.interface import InfraError

    try:
        return docker_client()
    except InfraError as e:
        if os.environ.get("CI"):
            pytest.fail(f"CI must have a Docker engine: {e}")
        pytest.skip(f"no Docker engine here ({e}); CI always has one")


@pytest.fixture(scope="session")
def images(docker_engine: Any) -> dict[str, str]:
    """Base, agent base, example agents and the hostile test containers, built offline."""
    from orchestrator._images.build import build_all, build_folder

    tags = {t: t for t in build_all(client=docker_engine, say=lambda m: None)}
    for name in TEST_IMAGES:
        tags[name] = build_folder(docker_engine, CONTAINERS / name, f"eagc-test/{name}:latest",
                                  say=lambda m: None)
    return tags


@pytest.fixture()
def runs_dir() -> Path:
    # Short on purpose: unix socket paths are limited to 108 bytes.
    import tempfile

    return Path(tempfile.mkdtemp(prefix="eagc-", dir="/tmp"))
