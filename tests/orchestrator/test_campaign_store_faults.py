"""The store under faults: an empty or damaged store next to existing results is refused
(naming `eagc campaign rebuild-store`), which rebuilds it from the episode folders; and an
embedded Ray never attaches to another cluster on the machine, without Ray's token warning.

Real drivers (``python -m orchestrator.cli.campaign``) on a real embedded Ray; the agents
are the sanity baseline as local processes (the store is what is tested here, not the
sandbox).
"""

from __future__ import annotations

import json
import os
import sqlite3
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from test_campaign_helpers import (
    RayCluster,
    end_processes,
    processes_mentioning,
    short_dir,
)

pytestmark = [pytest.mark.slow]

AGENT = Path(__file__).resolve().parents[2] / "examples" / "sanity_agent" / "agent.py"


@pytest.fixture()
def ray_tmp() -> Iterator[Path]:
    folder = short_dir("eagc-rs-")
    yield folder
    end_processes(processes_mentioning(str(folder)))


def _campaign(folder: Path, name: str, episodes: int = 2) -> Path:
    doc = {"name": name, "track": "sanity", "phase": "local", "runtime": "local",
           "splits": [{"name": "standard", "episodes": episodes}],
           "submissions": [{"team": "base", "image": f"python {AGENT}"}],
           "limits": {"memory_mb": 512, "max_steps_per_stage": 400}, "retries": 1,
           "output": str(folder / "out")}
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def _cli(ray_tmp: Path, *args: str, env: dict[str, str] | None = None
         ) -> subprocess.CompletedProcess[str]:
    full = {**os.environ, "RAY_TMPDIR": str(ray_tmp), "RAY_USAGE_STATS_ENABLED": "0",
            **(env or {})}
    full.pop("RAY_AUTH_MODE", None)  # as a fresh shell has it: the driver configures it
    return subprocess.run([sys.executable, "-m", "orchestrator.cli.campaign", *args],
                          env=full, capture_output=True, text=True, timeout=300)


def _rows(store: Path, name: str) -> list[tuple[Any, ...]]:
    db = sqlite3.connect(store)
    try:
        return db.execute("SELECT submission, split, idx, episode, status, score, retry "
                          "FROM episodes WHERE campaign=? ORDER BY idx", (name,)).fetchall()
    finally:
        db.close()


@pytest.mark.parametrize("damage", ["empty", "garbage"])
def test_a_lost_store_is_refused_then_rebuilt(ray_tmp: Path, damage: str) -> None:
    folder = short_dir("eagc-rb-")
    name = f"rebuild-{damage}-{os.urandom(3).hex()}"
    path = _campaign(folder, name, episodes=3)
    first = _cli(ray_tmp, "run", str(path), "--no-progress")
    assert first.returncode == 0, first.stderr[-3000:]
    assert "Token authentication" not in first.stderr  # issue 10 §2: configured, no warning
    store = folder / "out" / "results.sqlite"
    before = _rows(store, name)
    assert len(before) == 3
    assert (folder / "out").stat().st_mode & 0o777 == 0o700  # organizer-only
    for suffix in ("-wal", "-shm"):
        Path(str(store) + suffix).unlink(missing_ok=True)
    store.write_bytes(b"" if damage == "empty" else b"\x00garbage\xff" * 500)

    again = _cli(ray_tmp, "run", str(path), "--no-progress")
    assert again.returncode == 5, again.stderr[-3000:]  # refused: nothing ran twice
    assert "eagc campaign rebuild-store" in " ".join(again.stderr.split())
    assert "Traceback" not in again.stderr

    rebuilt = _cli(ray_tmp, "rebuild-store", str(path))
    assert rebuilt.returncode == 0, rebuilt.stderr[-3000:]
    assert "3 committed" in rebuilt.stderr
    assert _rows(store, name) == before
    if damage == "garbage":
        assert list((folder / "out").glob("results.sqlite.damaged-*"))

    resumed = _cli(ray_tmp, "run", str(path), "--no-progress")
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    assert "0 committed this run, 3 already in the store" in resumed.stderr
    status = _cli(ray_tmp, "status", str(path))
    assert status.returncode == 0 and "missing" in status.stdout


def test_embedded_ray_never_attaches_to_another_cluster(ray_tmp: Path) -> None:
    """Another cluster runs on the machine and RAY_ADDRESS points at it (as `ray start`
    tells a shell to): the campaign still starts a Ray of its own."""
    cluster = RayCluster()
    try:
        cluster.start_head(cpus=1, resources={"other_cluster": 1})
        folder = short_dir("eagc-ri-")
        path = _campaign(folder, "isolated-" + os.urandom(3).hex(), episodes=1)
        r = _cli(ray_tmp, "run", str(path), "--no-progress",
                 env={"RAY_ADDRESS": cluster.address})
        assert r.returncode == 0, r.stderr[-3000:]
        assert "Token authentication" not in r.stderr
        # The other cluster's nodes: none of them ran our episode.
        probe = (f"import ray, json; ray.init(address={cluster.address!r}); "
                 "print(json.dumps([n['NodeID'] for n in ray.nodes()]))")
        nodes = subprocess.run([sys.executable, "-c", probe], env=cluster.env,
                               capture_output=True, text=True, timeout=120)
        assert nodes.returncode == 0, nodes.stderr[-2000:]
        ours = {row[0] for row in sqlite3.connect(folder / "out" / "results.sqlite").execute(
            "SELECT node FROM episodes")}
        assert ours and not ours & set(json.loads(nodes.stdout.splitlines()[-1]))
    finally:
        cluster.stop()
