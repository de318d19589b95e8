"""Shared fixtures. Markers (``docker``, ``slow``) are registered in pyproject.toml.

Every test session has its own CPU lock folder (``own_lock_dir``): nothing in the suite
depends on the machine being empty.

``sim_host`` starts a real ``SimHost`` serving a real sanity episode (MuJoCo) on a unix
socket, with ``serve()`` on a thread; ``host_episode`` is one such host with the defaults.

Docker fixtures: ``docker_engine`` (a real engine; never skipped in CI), ``images`` (base,
agent base, example agents and the hostile test containers, built offline), ``runs_dir``.
"""

from __future__ import annotations

import os
import secrets
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

# Headless rendering (EGL on Mesa), set before any test imports mujoco: once mujoco has
# picked its default GL backend in this process, rendering without a display aborts.
os.environ.setdefault("MUJOCO_GL", "egl")

# Plain asserts in the shipped conformance suite get pytest's detailed failure messages.
pytest.register_assert_rewrite("plugins.conformance")


@pytest.fixture(scope="session", autouse=True)
def own_lock_dir(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """The CPU placement locks of this test session, apart from any other eagc run on the
    machine (``EAGC_LOCK_DIR`` defaults to /tmp, which a running campaign may hold: the
    tests must pass while one runs). Set before any episode, Ray worker or driver process
    starts, so that they all inherit it."""
    folder = tmp_path_factory.mktemp("cpu-locks")
    before = os.environ.get("EAGC_LOCK_DIR")
    os.environ["EAGC_LOCK_DIR"] = str(folder)
    yield folder
    if before is None:
        os.environ.pop("EAGC_LOCK_DIR", None)
    else:
        os.environ["EAGC_LOCK_DIR"] = before


@dataclass
class HostHandle:
    """A running sim host: where an agent connects, and how the episode ended."""

    host: Any  # simhost.SimHost
    episode: str
    endpoint: str
    stop: threading.Event
    thread: threading.Thread
    _outcome: list[Any] = field(default_factory=list)

    def outcome(self, timeout: float = 10.0) -> Any:
        """Waits for ``serve()`` to return; the episode's ``HostOutcome``."""
        self.thread.join(timeout)
        if self.thread.is_alive():
            raise TimeoutError(f"the host still serves after {timeout} s")
        if not self._outcome:
            raise RuntimeError("serve() raised; see the thread's traceback above")
        return self._outcome[0]


@pytest.fixture
def sim_host(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Callable[..., HostHandle]]:
    """Factory: ``sim_host(seed=1, split="standard", step_budgets=None, **HostConfig fields)
    -> HostHandle`` (``step_budgets``: the episode's own step caps by stage).

    Defaults keep the budgets out of the way (official 60 s stages, 30 s to start); pass
    ``time_scale``, ``max_steps_per_stage``, ``max_protocol_errors``, … to change them.
    """
    from plugins import load_track
    from schemas import unix_endpoint
    from simhost import HostConfig, SimHost

    handles: list[tuple[HostHandle, Any]] = []

    def start(*, seed: int = 1, split: str = "standard",
              step_budgets: dict[str, int] | None = None, **overrides: Any) -> HostHandle:
        track = load_track("sanity")
        episode = track.make_episode(track.make_scenario(seed=seed, split=split, params={}))
        if step_budgets is not None:  # the episode's own caps (TrackEpisode.step_budget)
            episode.step_budget = step_budgets.get  # type: ignore[method-assign]
        # A short folder: unix socket paths are limited to 108 bytes.
        sock = tmp_path_factory.mktemp("ep") / "sock" / "zenoh.sock"
        sock.parent.mkdir()
        endpoint = unix_endpoint(str(sock))
        config = {
            "episode": secrets.token_hex(8),
            "track": track.name,
            "endpoints": (endpoint,),
            "socket_path": sock,
            "startup_s": 30.0,
            "max_request_bytes": 64 * 1024,
            "max_protocol_errors": 50,
            **overrides,
        }
        host = SimHost(episode, track.stages(), HostConfig(**config))
        host.open()
        stop = threading.Event()
        outcome: list[Any] = []
        thread = threading.Thread(
            target=lambda: outcome.append(host.serve(stop, poll_s=0.02)), daemon=True
        )
        handle = HostHandle(host, config["episode"], endpoint, stop, thread, outcome)
        handles.append((handle, episode))
        thread.start()
        return handle

    yield start

    for handle, episode in handles:
        handle.stop.set()
        handle.thread.join(10)
        handle.host.close()
        episode.close()


@pytest.fixture
def host_episode(sim_host: Callable[..., HostHandle]) -> HostHandle:
    """A sanity episode served with the default settings, waiting for its agent."""
    return sim_host()


# ---------------------------------------------------------------------------- docker
CONTAINERS = Path(__file__).resolve().parent / "containers"
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


# ---------------------------------------------------------------------------- chromium
@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    """One headless Chromium for a module's pages (``tests/orchestrator/_chromium.py``);
    never skipped in CI."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent / "orchestrator"))
    from _chromium import Browser, chromium

    binary = chromium()
    if binary is None:
        msg = "chromium is not installed (apt-get install chromium)"
        if os.environ.get("CI"):
            pytest.fail(msg)
        pytest.skip(msg)
    b = Browser(binary)
    try:
        yield b
    finally:
        b.close()
