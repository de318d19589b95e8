"""Both runtimes run the runtime conformance suite (orchestrator/conformance.py).

DockerRuntime, the official one, runs the sandbox checks too, from inside a real container
on a real engine; LocalProcessRuntime (development only, no sandbox) runs the checks every
runtime owes the worker.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path
from typing import Any

import pytest

from orchestrator._runtimes.docker import DockerRuntime
from orchestrator._runtimes.local import LocalProcessRuntime
from orchestrator.conformance import (
    PROBE_SCRIPT,
    RuntimeConformance,
    SandboxConformance,
    probe_build_context,
)

PROBE_IMAGE = "eagc-test/runtime-probe:latest"


class TestLocalProcessRuntime(RuntimeConformance):
    @pytest.fixture
    def runtime(self) -> LocalProcessRuntime:
        return LocalProcessRuntime(quiet=True)

    @pytest.fixture
    def probe_image(self) -> str:
        return f"{sys.executable} -u {PROBE_SCRIPT}"


@pytest.fixture(scope="module")
def probe_image_built(docker_engine: Any, images: dict[str, str]) -> str:
    from orchestrator._images.build import build_folder

    with tempfile.TemporaryDirectory() as tmp:
        return build_folder(docker_engine, probe_build_context(Path(tmp) / "probe"),
                            PROBE_IMAGE, say=lambda m: None)


class TestDockerRuntime(SandboxConformance):
    @pytest.fixture
    def runtime(self, docker_engine: Any) -> DockerRuntime:
        return DockerRuntime(docker_engine)

    @pytest.fixture
    def probe_image(self, probe_image_built: str) -> str:
        return probe_image_built


def test_the_suite_catches_a_runtime_without_a_sandbox() -> None:
    """The sandbox checks fail on the local runtime: they can fail, so they check something."""
    suite = SandboxConformance()
    runtime = LocalProcessRuntime(quiet=True)
    image = f"{sys.executable} -u {PROBE_SCRIPT}"
    failures = []
    for check in (lambda: suite.test_runtime_is_official(runtime),
                  lambda: suite.test_identity_and_privileges(runtime, image)):
        try:
            check()
        except AssertionError as e:
            failures.append(str(e))
    assert len(failures) == 2, failures
    assert "official=False" in failures[0]


class _Loosened:
    """A docker client whose ``containers.run`` drops sandbox options: a broken runtime."""

    def __init__(self, client: Any, drop: set[str], extra: dict[str, Any]) -> None:
        self._client, self._drop, self._extra = client, drop, extra

    def __getattr__(self, name: str) -> Any:
        return getattr(self._client, name)

    @property
    def containers(self) -> Any:
        outer = self

        class Containers:
            def __getattr__(self, name: str) -> Any:
                return getattr(outer._client.containers, name)

            def run(self, image: str, **kwargs: Any) -> Any:
                kept = {k: v for k, v in kwargs.items() if k not in outer._drop}
                return outer._client.containers.run(image, **{**kept, **outer._extra})

        return Containers()


def test_the_suite_catches_a_loosened_docker_sandbox(
    docker_engine: Any, probe_image_built: str
) -> None:
    """Each sandbox check fails once its part of the sandbox is taken away."""
    suite = SandboxConformance()
    cases = {
        "identity": ({"user", "cap_drop", "security_opt"}, {},
                     suite.test_identity_and_privileges),
        "filesystem": ({"read_only", "tmpfs"}, {}, suite.test_filesystem),
        "network": ({"network_mode"}, {}, suite.test_no_network),
        "pids": ({"pids_limit"}, {}, suite.test_pids_limit_holds_a_fork_bomb),
    }
    caught = {}
    for name, (drop, extra, check) in cases.items():
        runtime = DockerRuntime(_Loosened(docker_engine, drop, extra))
        try:
            check(runtime, probe_image_built)
            caught[name] = "passed"
        except AssertionError as e:
            caught[name] = f"caught: {str(e)[:120]}"
    assert all(v.startswith("caught") for v in caught.values()), caught
