"""``eagc demo`` without the sandbox (issue 23 §2): what it prints is true.

The local demo runs as campaign ``<demo>-local`` (its results never pass for the sandbox's),
so its seeds, episodes, scores and ranks differ from a Docker demo's: it says so. Its "see
again" commands show its results (not an empty board of the demo file), in 80 columns.
The real command in a process of its own, an embedded Ray, the sanity demo.
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

import pytest

from orchestrator._campaign.seeds import load_secret, seed_list
from orchestrator._campaign.spec import load_campaign
from orchestrator.cli.demo import DEMOS, _as_local


def _eagc(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "COLUMNS": "80"}
    return subprocess.run([sys.executable, "-c", "from orchestrator.cli import main; main()",
                           *args], capture_output=True, text=True, env=env, timeout=900)


@pytest.fixture()
def out() -> Iterator[Path]:
    folder = Path(tempfile.mkdtemp(prefix="eagc-dl-", dir="/tmp"))  # short: socket paths
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def test_the_local_demo_plays_other_seeds_than_the_docker_demo() -> None:
    """What the note says: the local campaign's name, hence its seeds, differ."""
    spec = load_campaign(DEMOS / "demo_sanity.yaml")
    local = _as_local(spec)
    assert local.name == "demo-sanity-local" and local.runtime == "local"
    seeds = [s.seed for s in seed_list(spec, load_secret(spec))]
    assert not set(seeds) & {s.seed for s in seed_list(local, load_secret(local))}


@pytest.mark.slow
def test_the_local_demo_says_why_it_ranks_apart_and_shows_its_results(out: Path) -> None:
    r = _eagc("demo", "--runtime", "local", "--track", "sanity", "--output", str(out))
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
    assert "Traceback" not in r.stderr
    said = " ".join(r.stderr.split())
    assert ("as campaigns <demo>-local beside the Docker demo's. Seeds derive from a "
            "campaign's name, so these episodes, scores and ranks differ from a Docker "
            "run's.") in said, r.stderr
    assert all(len(line) <= 80 for line in r.stdout.splitlines())
    assert all(len(line) <= 80 for line in r.stderr.splitlines() if str(out) not in line)
    shown = out / "demo_sanity_local.yaml"
    assert f"see again:\n  eagc leaderboard {shown}\n" in r.stderr

    board = _eagc("leaderboard", str(shown), "--format", "json")
    assert board.returncode == 0, board.stderr
    doc = json.loads(board.stdout)
    assert doc["campaign"] == "demo-sanity-local"
    assert [(row["team"], row["episodes"]) for row in doc["rows"]] == [("sanity_agent", 4)]

    again = _eagc("demo", "--runtime", "local", "--track", "sanity", "--output", str(out))
    assert again.returncode == 0, again.stderr[-3000:]
    assert "4 episode(s) were already in the store" in again.stderr
    assert again.stdout == r.stdout


@pytest.mark.parametrize("demo", sorted(p.name for p in DEMOS.glob("demo_*.yaml")))
def test_a_demo_with_its_own_output_finds_its_teams_disclosures(
        demo: str, out: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``eagc demo --output DIR`` (the quickstart's) reads the demo file's relative paths
    against the file, from any working directory."""
    from orchestrator.cli.demo import _load

    monkeypatch.chdir(tmp_path)
    spec = _load(DEMOS / demo, out)
    named = [s.disclosure for s in spec.submissions if s.disclosure is not None]
    assert named and all(p.is_absolute() and p.is_file() for p in named), named
