"""``eagc demo`` (issue 10 §2): fixed campaign files, fixed seeds, the same leaderboard twice,
results a user can find and inspect again.

The real command in a process of its own, real containers (the sanity demo: the other
demos run the same code with other files), an embedded Ray.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

#: Measured, not scored: they differ from run to run.
MEASURED = {"latency_ms", "peak_mem_gb", "runtime_min"}


def _eagc(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "COLUMNS": "80"}
    return subprocess.run([sys.executable, "-c", "from orchestrator.cli import main; main()",
                           *args], capture_output=True, text=True, env=env, timeout=900)


@pytest.fixture()
def two_dirs() -> Iterator[tuple[Path, Path]]:
    dirs = tuple(Path(tempfile.mkdtemp(prefix="eagc-dm-", dir="/tmp")) for _ in range(2))
    yield dirs  # type: ignore[misc]
    for d in dirs:
        shutil.rmtree(d, ignore_errors=True)


@pytest.mark.docker
@pytest.mark.slow
def test_the_demo_twice_prints_the_same_leaderboard(docker_engine: Any, images: dict,
                                                    two_dirs: tuple[Path, Path]) -> None:
    runs = [_eagc("demo", "--track", "sanity", "--output", str(d)) for d in two_dirs]
    for r, d in zip(runs, two_dirs, strict=True):
        assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
        assert "Traceback" not in r.stderr
        assert all(len(line) <= 80 for line in r.stdout.splitlines())
        assert all(len(line) <= 80 for line in r.stderr.splitlines()
                   if str(d) not in line), "only a line that holds a long path may be wider"
        assert f"results of demo-sanity (SQLite, one row per episode):\n  {d}/results.sqlite" \
            in r.stderr
        assert f"eagc leaderboard {d}/demo_sanity.yaml" in r.stderr

    boards = []
    for d in two_dirs:
        r = _eagc("leaderboard", str(d / "demo_sanity.yaml"), "--format", "json")
        assert r.returncode == 0, r.stderr
        doc = json.loads(r.stdout)
        assert doc["campaign"] == "demo-sanity"
        boards.append({row["team"]: (row["episodes"], {k: v for k, v in row["values"].items()
                                                       if k not in MEASURED})
                       for row in doc["rows"]})
    assert boards[0] == boards[1]  # same seeds, same episodes, same scores
    (episodes, values), = boards[0].values()
    assert episodes == 4 and 0 <= values["final"] <= 100

    status = _eagc("status", str(two_dirs[0] / "demo_sanity.yaml"))
    assert status.returncode == 0 and "missing" in status.stdout

    again = _eagc("demo", "--track", "sanity", "--output", str(two_dirs[0]))
    assert again.returncode == 0, again.stderr[-3000:]
    assert "4 episode(s) were already in the store" in again.stderr
    assert again.stdout == runs[0].stdout  # nothing run again: the stored leaderboard
