"""The driver's own faults (issue 13 §1, §2, §4): a killed driver, a full disk, the whole Ray
gone. Real drivers, real embedded Ray, real containers; in each case what was committed
stays, no container or output mount is left behind, and nobody's episode is charged a
retry for a fault that was not on its own node."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import time
from pathlib import Path
from typing import Any

import docker
import pytest
from test_campaign_faults import WAITING, _driver, _events, _rows, _running_episode, _wait
from test_campaign_faults import ray_tmp as ray_tmp  # noqa: F401 - the fixture
from test_campaign_helpers import (
    build_campaign_images,
    end_processes,
    processes_mentioning,
    short_dir,
    write_campaign,
)

pytestmark = [pytest.mark.docker, pytest.mark.slow]


def _containers(name: str) -> list[Any]:
    return docker.from_env().containers.list(all=True,
                                             filters={"label": f"eagc.campaign={name}"})


def _mounts(folder: Path) -> list[str]:
    return [line for line in Path("/proc/self/mounts").read_text().splitlines()
            if line.startswith("eagc-output ") and str(folder) in line]


def _running(folder: Path, name: str, n: int) -> Any:
    return lambda: len(docker.from_env().containers.list(
        filters={"label": f"eagc.campaign={name}", "status": "running"})) >= n


def _holding(folder: Path) -> list[int]:
    """Pids with a file open under ``folder`` (Ray's agents rename themselves, so their
    command lines do not name it)."""
    from orchestrator._programs.ray_sentinel import _holds

    return [int(d.name) for d in Path("/proc").iterdir()
            if d.name.isdigit() and _holds(int(d.name), str(folder))]


def test_a_dead_drivers_containers_are_gone_within_a_minute(docker_engine: Any,
                                                             ray_tmp: Path) -> None:  # noqa: F811
    """SIGKILL of the driver alone, nothing run afterwards: its containers (episodes of
    minutes) are removed within a minute by their episode watchers, and what it started of
    its embedded Ray (the dashboard and runtime-env agents lived on for minutes) by its
    sentinel, with Ray's temp dir, unattended."""
    build_campaign_images(docker_engine, "waiting")
    folder = short_dir("eagc-dd-")
    name = "dead-driver-" + os.urandom(3).hex()  # unique on a shared engine
    path = write_campaign(folder, name, WAITING, standard=1, challenge=1,
                          limits={"memory_mb": 256, "max_steps_per_stage": 3000})
    proc = _driver(path, ray_tmp, "--workers", "2")
    _wait("two running containers", _running(folder, name, 2), 120, proc)
    proc.send_signal(signal.SIGKILL)
    proc.wait(10)
    killed = time.time()
    while _containers(name) and time.time() - killed < 60:
        time.sleep(1)
    left = [c.name for c in _containers(name)]
    assert left == [], f"still there a minute after the driver died: {left}"
    while (_holding(ray_tmp) or any(ray_tmp.iterdir())) and time.time() - killed < 60:
        time.sleep(1)
    assert _holding(ray_tmp) == [], "Ray processes outlived their driver by a minute"
    assert list(ray_tmp.iterdir()) == [], "the embedded Ray's temp dir was left behind"


def test_a_full_disk_stops_the_campaign_cleanly(docker_engine: Any, ray_tmp: Path  # noqa: F811
                                                 ) -> None:
    """The output folder is a small filesystem that fills up mid-campaign: one message,
    exit 5, containers and output mounts gone, every committed result still there, and
    rebuild-store plus a second run finish the campaign once there is room."""
    build_campaign_images(docker_engine, "waiting")
    folder = short_dir("eagc-df-")
    name = "disk-full-" + os.urandom(3).hex()
    out = folder / "out"
    out.mkdir()
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=48m", "eagc-test-disk", str(out)],
                   check=True)
    try:
        path = write_campaign(folder, name, WAITING, standard=4, challenge=2,
                              limits={"memory_mb": 256, "max_steps_per_stage": 15})
        proc = _driver(path, ray_tmp, "--workers", "2")
        _wait("a committed episode and two running",
              lambda: len(_rows(folder, name)) >= 1 and _running(folder, name, 2)(), 180, proc)
        with (out / "filler").open("wb") as f:  # everything that is left
            try:
                while True:
                    f.write(b"\0" * (1 << 20))
                    f.flush()
            except OSError:
                pass
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == 5, err[-3000:]
        assert "Traceback" not in err
        flat = " ".join(err.split())
        assert "could not write" in flat and "committed are kept" in flat, flat[-1500:]
        assert _containers(name) == []
        assert _mounts(folder) == []
        (out / "filler").unlink()
        kept = _rows(folder, name)
        assert len(kept) >= 1
        assert sqlite3.connect(out / "results.sqlite").execute(
            "SELECT COUNT(*) FROM attempts").fetchone() == (0,)  # nobody was charged
        again = _driver(path, ray_tmp, "--workers", "2")
        _, err = again.communicate(timeout=300)
        assert again.returncode == 0, err[-3000:]
        after = _rows(folder, name)
        assert len(after) == 6 and set(kept) <= set(after)
    finally:
        subprocess.run(["umount", "-l", str(out)], capture_output=True)


def test_losing_the_whole_ray_stops_the_campaign_cleanly(docker_engine: Any,
                                                         ray_tmp: Path) -> None:  # noqa: F811
    """Every Ray process of the campaign is killed (GCS, raylet, workers): the driver says
    so in one line within seconds (not Ray's 60 s abort), exits 6, removes its containers,
    keeps what was committed, and charges no in-flight episode a retry. Beside two
    busy-looping processes on a 2-core machine it noticed within 0.0-1.9 s and exited within
    0.7-2.3 s, ten runs in a row (issue 37); before, it could wait in ``ray.nodes()`` for the
    dead GCS until Ray's abort, and ``-s`` prints both times."""
    build_campaign_images(docker_engine, "waiting")
    folder = short_dir("eagc-rl-")
    name = "ray-lost-" + os.urandom(3).hex()
    path = write_campaign(folder, name, WAITING, standard=2, challenge=1,
                          limits={"memory_mb": 256, "max_steps_per_stage": 1500})
    proc = _driver(path, ray_tmp, "--workers", "2")
    _wait("two episodes in running containers",
          lambda: _running(folder, name, 2)() and _running_episode(folder, name, 0), 180, proc)
    ray = processes_mentioning(str(ray_tmp)) - {proc.pid}
    assert ray, "no Ray processes found"
    lost = time.time()
    end_processes(ray, grace_s=0.5)
    try:
        _, err = proc.communicate(timeout=50)  # Ray alone would abort only after 60 s
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
        pytest.fail(f"the driver had not exited 50 s after its Ray was killed:\n{err[-3000:]}")
    took = time.time() - lost
    assert proc.returncode == 6, (proc.returncode, err[-3000:])
    flat = " ".join(err.split())
    assert "Ray cluster stopped answering" in flat and "Traceback" not in err, flat[-1500:]
    assert len([ln for ln in err.splitlines() if ln.startswith("error:")]) == 1, err[-3000:]
    assert _containers(name) == [], f"left after {took:.0f} s"
    db = sqlite3.connect(folder / "out" / "results.sqlite")
    assert db.execute("SELECT * FROM attempts").fetchall() == [], err[-3000:]
    failed = [e for e in _events(folder, name) if e["event"] == "failed"]
    assert len(failed) == 1 and failed[0]["reason"] == "cluster"
    print(f"\ncluster lost: noticed after {failed[0]['at'] - lost:.1f} s, "
          f"driver exited after {took:.1f} s")


def test_an_unreachable_cluster_is_one_line_and_exit_6(ray_tmp: Path) -> None:  # noqa: F811
    """``--address`` of a port where no Ray head listens: one line naming the address and
    how to start a head, exit 6, within seconds (Ray alone retries for minutes), and no
    episode run."""
    import socket

    with socket.socket() as s:  # a free port, closed again: nothing listens there
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    folder = short_dir("eagc-ua-")
    name = "unreachable-" + os.urandom(3).hex()
    path = write_campaign(folder, name, WAITING, standard=1, challenge=1)
    proc = _driver(path, ray_tmp, "--address", f"127.0.0.1:{port}")
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 6, err[-2000:]
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1 and f"no Ray cluster answers at 127.0.0.1:{port}" in lines[0]
    assert "ray start --head" in lines[0] and "Traceback" not in err
    assert _rows(folder, name) == []
