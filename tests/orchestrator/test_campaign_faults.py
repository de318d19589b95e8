"""Faults: a worker killed mid-episode, a driver killed mid-campaign and started again.

The drivers are real processes (``python -m orchestrator.cli.campaign run``) on their own
embedded Ray, in a temp dir of their own (``RAY_TMPDIR``) so that whatever a killed driver
leaves behind is found and ended by this test, and only that.
"""

from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import docker
import pytest
from test_campaign_helpers import (
    build_campaign_images,
    end_processes,
    processes_mentioning,
    short_dir,
    write_campaign,
)

pytestmark = [pytest.mark.docker, pytest.mark.slow]

WAITING = {"waiting": "eagc-test/waiting:latest"}


@pytest.fixture()
def ray_tmp() -> Iterator[Path]:
    folder = short_dir("eagc-rt-")
    yield folder
    end_processes(processes_mentioning(str(folder)))


def _driver(path: Path, ray_tmp: Path, *args: str) -> subprocess.Popen[str]:
    """A driver in a process group of its own (as a shell's foreground job would be), with
    SIGINT at its default whatever this test process inherited (a shell starts background
    jobs with SIGINT ignored, and an ignored signal stays ignored across exec)."""
    env = {**os.environ, "RAY_TMPDIR": str(ray_tmp), "RAY_USAGE_STATS_ENABLED": "0"}
    return subprocess.Popen(
        [sys.executable, "-m", "orchestrator.cli.campaign", "run", str(path), "--no-progress",
         *args], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # noqa: PLW1509


def _events(folder: Path, name: str) -> list[dict[str, Any]]:
    path = folder / "out" / name / "events.jsonl"
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _rows(folder: Path, name: str) -> list[tuple[Any, ...]]:
    path = folder / "out" / "results.sqlite"
    if not path.exists():
        return []
    db = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=10)
    try:
        return db.execute("SELECT submission, split, idx, episode, retry, committed_at "
                          "FROM episodes WHERE campaign=? ORDER BY split, idx",
                          (name,)).fetchall()
    except sqlite3.OperationalError:  # tables not created yet
        return []
    finally:
        db.close()


def _wait(what: str, check: Any, timeout: float, proc: subprocess.Popen[str]) -> Any:
    deadline = time.time() + timeout
    while time.time() < deadline:
        got = check()
        if got:
            return got
        if proc.poll() is not None:
            out, err = proc.communicate()
            pytest.fail(f"the driver ended (rc {proc.returncode}) before {what}:\n{err[-3000:]}")
        time.sleep(0.2)
    proc.kill()
    pytest.fail(f"timed out waiting for {what}")


def _no_containers(name: str) -> None:
    left = docker.from_env().containers.list(all=True, filters={"label": f"eagc.campaign={name}"})
    assert left == [], [c.name for c in left]


def _running_episode(folder: Path, name: str, retry: int) -> dict[str, Any] | None:
    """The "started" report of an episode of ``retry`` whose container runs, if any."""
    engine = docker.from_env()
    for ev in _events(folder, name):
        if ev["event"] == "started" and ev["retry"] == retry and engine.containers.list(
                filters={"label": f"eagc.episode={ev['episode']}", "status": "running"}):
            return ev
    return None


def test_killed_workers_retry_quarantine_and_release(docker_engine: Any, ray_tmp: Path) -> None:
    """Kill the worker of an episode: retried. Kill its retry's too: quarantined (retries: 1),
    the leaderboard holds that final back. ``--retry-quarantined``: committed, exactly once."""
    build_campaign_images(docker_engine, "waiting")
    folder = short_dir("eagc-fw-")
    name = "kill-worker-" + os.urandom(3).hex()  # unique on a shared engine
    # ~4 s episodes: 20 steps of 0.1 s in each of the two stages.
    path = write_campaign(folder, name, WAITING, standard=2, challenge=1, retries=1,
                          limits={"memory_mb": 256, "max_steps_per_stage": 20})
    proc = _driver(path, ray_tmp, "--workers", "1")
    victim = _wait("an episode in a running container",
                   lambda: _running_episode(folder, name, 0), 120, proc)
    key = (victim["submission"], victim["split"], victim["index"])
    os.kill(victim["pid"], signal.SIGKILL)  # the Ray worker process running that episode

    def retry_of_key() -> dict[str, Any] | None:
        ev = _running_episode(folder, name, 1)
        return ev if ev and (ev["submission"], ev["split"], ev["index"]) == key else None

    second = _wait("the retry in a running container", retry_of_key, 120, proc)
    os.kill(second["pid"], signal.SIGKILL)
    out, err = proc.communicate(timeout=240)
    assert proc.returncode == 3, err[-3000:]  # 3: something is quarantined

    rows = _rows(folder, name)
    assert len(rows) == 2 and key not in {r[:3] for r in rows}
    events = _events(folder, name)
    retries = [e for e in events if e["event"] == "retry"]
    assert [(e["submission"], e["split"], e["index"], e["retry"]) for e in retries] == [
        (*key, 0)]
    assert "died" in retries[0]["message"].lower() or "worker" in retries[0]["message"].lower()
    assert [e["episode"] for e in events if e["event"] == "quarantined"] == [second["episode"]]
    db = sqlite3.connect(folder / "out" / "results.sqlite")
    attempts = db.execute("SELECT retry, episode FROM attempts WHERE campaign=? ORDER BY retry",
                          (name,)).fetchall()
    assert attempts == [(0, victim["episode"]), (1, second["episode"])]
    _no_containers(name)  # the dead workers' containers were found by label and removed
    mounts = Path("/proc/self/mounts").read_text()
    assert victim["episode"] not in mounts and second["episode"] not in mounts

    board = subprocess.run([sys.executable, "-m", "orchestrator.cli.campaign", "leaderboard",
                            str(path), "--format", "json"], capture_output=True, text=True)
    doc = json.loads(board.stdout)
    assert doc["rows"][0]["state"] == "pending" and doc["rows"][0]["quarantined"] == 1
    (held,) = [f for f in doc["failures"] if f["status"] == "quarantined"]
    assert (held["team"], held["split"], held["index"]) == key
    assert "Worker" not in held["message"]  # no infrastructure internals for the teams

    # An organizer decides to run it again.
    again = _driver(path, ray_tmp, "--workers", "1", "--retry-quarantined")
    out, err = again.communicate(timeout=240)
    assert again.returncode == 0, err[-3000:]
    rows = _rows(folder, name)
    assert len(rows) == 3 and len({r[:3] for r in rows}) == 3
    (row,) = [r for r in rows if r[:3] == key]
    assert row[4] == 2 and row[3] not in (victim["episode"], second["episode"])
    committed = [e for e in _events(folder, name) if e["event"] == "committed"
                 and (e["submission"], e["split"], e["index"]) == key]
    assert len(committed) == 1
    assert db.execute("SELECT COUNT(*) FROM quarantine").fetchone() == (0,)
    board = subprocess.run([sys.executable, "-m", "orchestrator.cli.campaign", "leaderboard",
                            str(path), "--format", "json"], capture_output=True, text=True)
    assert json.loads(board.stdout)["rows"][0]["state"] == "final"


def test_killed_driver_resumes_without_loss_or_duplicates(docker_engine: Any,
                                                          ray_tmp: Path) -> None:
    build_campaign_images(docker_engine, "waiting")
    folder = short_dir("eagc-fd-")
    name = "kill-driver-" + os.urandom(3).hex()
    path = write_campaign(folder, name, WAITING, standard=4, challenge=2,
                          limits={"memory_mb": 256, "max_steps_per_stage": 10})
    first = _driver(path, ray_tmp, "--workers", "1")
    _wait("two committed episodes", lambda: len(_rows(folder, name)) >= 2, 180, first)
    ray_processes = processes_mentioning(str(ray_tmp))
    first.send_signal(signal.SIGKILL)
    first.wait(10)
    before = _rows(folder, name)
    assert 2 <= len(before) < 6
    end_processes(ray_processes)  # what the killed driver's embedded Ray left, if anything

    second = _driver(path, ray_tmp, "--workers", "1")
    out, err = second.communicate(timeout=240)
    assert second.returncode == 0, err[-3000:]
    assert f"{6 - len(before)} committed this run, {len(before)} already in the store" in err

    after = _rows(folder, name)
    assert len(after) == 6 and len({r[:3] for r in after}) == 6
    assert set(before) <= set(after), "a committed result changed after the restart"
    committed = [(e["split"], e["index"]) for e in _events(folder, name)
                 if e["event"] == "committed"]
    assert sorted(committed) == sorted(set(committed)) and len(committed) == 6
    assert not [e for e in _events(folder, name) if e["event"] == "duplicate"]
    _no_containers(name)  # the restarted driver removed what the killed one left running


def test_ctrl_c_cancels_cleanly(docker_engine: Any, ray_tmp: Path) -> None:
    """Ctrl-C (SIGINT to the driver's whole process group, as a terminal sends it): the
    running episodes stop, their containers go, committed results stay, and nothing is
    counted as an infrastructure failure. Started again, the campaign finishes."""
    build_campaign_images(docker_engine, "waiting")
    folder = short_dir("eagc-fc-")
    name = "ctrl-c-" + os.urandom(3).hex()
    path = write_campaign(folder, name, WAITING, standard=3, challenge=1,
                          limits={"memory_mb": 256, "max_steps_per_stage": 20})
    proc = _driver(path, ray_tmp, "--workers", "2")
    _wait("a committed episode and one running",
          lambda: _rows(folder, name) and _running_episode(folder, name, 0), 180, proc)
    os.killpg(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err[-3000:]
    assert "cancelling" in err
    kept = _rows(folder, name)
    assert 1 <= len(kept) < 4
    _no_containers(name)
    db = sqlite3.connect(folder / "out" / "results.sqlite")
    assert db.execute("SELECT COUNT(*) FROM attempts").fetchone() == (0,)
    assert db.execute("SELECT COUNT(*) FROM quarantine").fetchone() == (0,)
    assert "eagc-output" not in " ".join(line for line in Path("/proc/self/mounts").read_text()
                                         .splitlines() if str(folder) in line)
    assert [e["event"] for e in _events(folder, name)].count("cancelled") == 1

    again = _driver(path, ray_tmp, "--workers", "2")
    out, err = again.communicate(timeout=240)
    assert again.returncode == 0, err[-3000:]
    after = _rows(folder, name)
    assert len(after) == 4 and set(kept) <= set(after)
