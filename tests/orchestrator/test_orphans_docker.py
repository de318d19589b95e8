"""Docker agents never outlive their episode: the reaper, `eagc cleanup` and the episode
watcher (real engine, real containers; heartbeats are real files whose age is set by hand
where the test cannot wait 30 s for one to go stale)."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import docker.errors
import pytest
from test_campaign_helpers import build_campaign_images

from orchestrator._runtimes.docker import DockerRuntime
from orchestrator._runtimes.interface import AgentLaunch
from orchestrator._runtimes.reaper import HEARTBEAT_LABEL, reap_stale
from schemas import Limits

pytestmark = [pytest.mark.docker]

IMAGE = "eagc-test/waiting:latest"
STALE = 5.0


def _cleanup(*args: str) -> subprocess.CompletedProcess[str]:
    """`eagc cleanup` as a process of its own, with heartbeats stale after STALE s."""
    return subprocess.run([sys.executable, "-m", "orchestrator.cli", "cleanup", *args],
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "EAGC_HEARTBEAT_STALE_S": str(STALE),
                               "COLUMNS": "200"})


@pytest.fixture()
def campaign(docker_engine: Any) -> Iterator[str]:
    build_campaign_images(docker_engine, "waiting")
    name = "orph-" + os.urandom(4).hex()
    yield name
    for c in docker_engine.containers.list(all=True, ignore_removed=True,
                                           filters={"label": f"eagc.campaign={name}"}):
        try:
            c.remove(force=True)
        except docker.errors.NotFound:  # the watcher or the reaper was quicker
            pass


def _sleeper(engine: Any, campaign: str, tag: str, heartbeat: str | None) -> Any:
    labels = {"eagc.managed": "true", "eagc.campaign": campaign, "eagc.episode": tag}
    if heartbeat is not None:
        labels[HEARTBEAT_LABEL] = heartbeat
    return engine.containers.run(IMAGE, ["sleep", "300"], detach=True, labels=labels,
                                 name=f"eagc-{campaign}-{tag}", network_mode="none")


def _exists(engine: Any, name: str) -> bool:
    return bool(engine.containers.list(all=True, filters={"name": name}))


@contextmanager
def _kept_at_age(ages: dict[Path, float]) -> Iterator[None]:
    """Sets each heartbeat's mtime to its age (s) now and every 0.2 s until the block ends,
    like a live worker (age 0) or one dead for that long: a fresh heartbeat must stay under
    STALE, and a stale one under the 30 s of other campaigns' reapers, however long the
    containers take to start."""
    done = threading.Event()

    def set_ages() -> None:
        now = time.time()
        for path, age in ages.items():
            os.utime(path, (now - age, now - age))

    def touch() -> None:
        while not done.wait(0.2):
            set_ages()

    set_ages()
    toucher = threading.Thread(target=touch, daemon=True)
    toucher.start()
    try:
        yield
    finally:
        done.set()
        toucher.join()


def test_only_stale_heartbeats_are_reaped(docker_engine: Any, campaign: str) -> None:
    """Of four agents, only the one whose heartbeat is readable and stale goes: a fresh
    heartbeat, one this machine cannot read (another node's folder) and none at all stay.
    `eagc cleanup` does the same (a dry run first); `--campaign` takes them all.

    "Stale" is 5 s here and the stale heartbeat 15 s old: other campaigns' reapers on this
    machine (30 s) must not take this test's container before it looks."""
    folder = Path(tempfile.mkdtemp(prefix="eagc-hb-", dir="/tmp"))
    stale, fresh = folder / "stale", folder / "fresh"
    stale.touch()
    fresh.touch()
    with _kept_at_age({fresh: 0.0, stale: 15.0}):
        for tag, hb in (("stale", str(stale)), ("fresh", str(fresh)),
                        ("elsewhere", "/nonexistent/ep0/heartbeat"), ("unlabelled", None)):
            _sleeper(docker_engine, campaign, tag, hb)
        dry = _cleanup("--dry-run")
        assert dry.returncode == 0, dry.stderr
        assert f"eagc-{campaign}-stale" in dry.stdout
        assert f"eagc-{campaign}-fresh" not in dry.stdout
        assert _exists(docker_engine, f"eagc-{campaign}-stale")  # nothing removed by a dry run
        removed = reap_stale(docker_engine, stale_s=STALE)
        assert f"eagc-{campaign}-stale" in removed
        assert not any(n.startswith(f"eagc-{campaign}-") and n != f"eagc-{campaign}-stale"
                       for n in removed)
        for tag in ("fresh", "elsewhere", "unlabelled"):
            assert _exists(docker_engine, f"eagc-{campaign}-{tag}"), tag
    named = _cleanup("--campaign", campaign)
    assert named.returncode == 0 and "removed 3 container(s)" in named.stdout, named.stdout
    assert not docker_engine.containers.list(all=True,
                                             filters={"label": f"eagc.campaign={campaign}"})


def _launch(folder: Path, campaign: str, deadline_s: float) -> AgentLaunch:
    for d in ("sock", "output"):
        (folder / d).mkdir(parents=True, exist_ok=True)
    (folder / "heartbeat").touch()
    return AgentLaunch(image=IMAGE, episode="ep" + os.urandom(8).hex(),
                       socket_dir=folder / "sock", output_dir=folder / "output",
                       limits=Limits(memory_mb=256), labels={"campaign": campaign},
                       heartbeat=folder / "heartbeat", deadline_s=deadline_s)


def _gone_within(engine: Any, container_id: str, timeout: float) -> bool:
    deadline = time.time() + timeout
    while time.time() < deadline:
        if not engine.containers.list(all=True, filters={"id": container_id}):
            return True
        time.sleep(0.2)
    return False


def test_the_episode_watcher_bounds_a_container_without_its_worker(
        docker_engine: Any, campaign: str) -> None:
    """Nobody calls stop(): the watcher (a process of its own) removes the container when
    the heartbeat goes away, and at the hard deadline while the heartbeat is fresh."""
    runtime = DockerRuntime(docker_engine)
    folder = Path(tempfile.mkdtemp(prefix="eagc-wa-", dir="/tmp"))
    handle = runtime.start(_launch(folder / "a", campaign, deadline_s=600))
    time.sleep(3)
    assert docker_engine.containers.get(handle.id).status == "running"
    (folder / "a" / "heartbeat").unlink()  # the episode folder's worker is gone
    assert _gone_within(docker_engine, handle.id, 15), "the watcher left the container"

    handle = runtime.start(_launch(folder / "b", campaign, deadline_s=4))
    end = time.time() + 30
    while time.time() < end and not _gone_within(docker_engine, handle.id, 0.5):
        os.utime(folder / "b" / "heartbeat")  # a live worker, but past the deadline
    assert _gone_within(docker_engine, handle.id, 1), "the hard deadline was not enforced"


@pytest.mark.parametrize("remover", ["reap_stale", "DockerRuntime.cleanup", "eagc cleanup"])
def test_a_container_removed_between_listing_and_inspection_is_skipped(
        docker_engine: Any, campaign: str, remover: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """The engine lists ids, then the SDK inspects each one. A container another process
    removes in between (here: removed for real from inside that inspection) is skipped;
    the other stale container still goes, and nothing raises ``NotFound``."""
    from docker.models.containers import ContainerCollection

    from orchestrator._runtimes.cleanup import cleanup

    stale = Path(tempfile.mkdtemp(prefix="eagc-hb-", dir="/tmp")) / "heartbeat"
    stale.touch()
    os.utime(stale, (time.time() - 15, time.time() - 15))
    victim = _sleeper(docker_engine, campaign, "victim", str(stale))
    other = _sleeper(docker_engine, campaign, "other", str(stale))
    real_get = ContainerCollection.get
    raced: list[str] = []

    def get(self: Any, container_id: str) -> Any:
        if container_id in (victim.id, victim.name) and not raced:
            raced.append(container_id)
            docker_engine.api.remove_container(victim.id, force=True)
        return real_get(self, container_id)

    monkeypatch.setattr(ContainerCollection, "get", get)
    if remover == "reap_stale":
        removed = reap_stale(docker_engine, stale_s=STALE)
    elif remover == "DockerRuntime.cleanup":
        removed = DockerRuntime(docker_engine).cleanup({"campaign": campaign})
    else:
        removed = cleanup(campaign=campaign, client=docker_engine).containers
    assert raced, "the listing never inspected the victim"
    assert other.name in removed and victim.name not in removed
    assert not _exists(docker_engine, victim.name) and not _exists(docker_engine, other.name)
