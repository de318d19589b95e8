"""``eagc run-episode`` and ``eagc test`` exit codes a script can use (issue 10 §3):
0 completed, 4 the agent failed, 3 infrastructure failure (never 2, the usage error).

Real episodes (MuJoCo sanity track, real Zenoh) with agents as local processes.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from orchestrator.cli.common import ExitCode
from orchestrator.cli.main import _episode_exit, app
from schemas import EpisodeResult, EpisodeStats, EpisodeStatus, ScoreCard

REPO = Path(__file__).resolve().parents[2]
SANITY = f"{sys.executable} {REPO / 'examples' / 'sanity_agent' / 'agent.py'}"
CRASH = f"{sys.executable} -c 'import sys; print(\"bad agent\"); sys.exit(7)'"


@pytest.fixture()
def runs() -> Iterator[Path]:
    folder = Path(tempfile.mkdtemp(prefix="eagc-re-", dir="/tmp"))  # short: socket paths
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def _run(*args: str) -> tuple[int, str, str]:
    r = CliRunner().invoke(app, list(args), env={"COLUMNS": "100"})
    return r.exit_code, r.stdout, r.stderr


@pytest.mark.slow
def test_a_completed_episode_exits_0_and_says_where_its_files_are(runs: Path) -> None:
    code, out, err = _run("run-episode", "sanity", "--runtime", "local", "--image", SANITY,
                          "--runs-dir", str(runs), "--max-steps", "300")
    assert code == ExitCode.OK, out + err
    assert "completed" in out
    (folder,) = runs.iterdir()
    assert f"episode folder: {folder}" in out
    assert (folder / "host" / "result.json").is_file()


@pytest.mark.slow
def test_an_agent_failure_exits_4(runs: Path) -> None:
    code, out, err = _run("run-episode", "sanity", "--runtime", "local", "--image", CRASH,
                          "--runs-dir", str(runs), "--json")
    assert code == ExitCode.AGENT, out + err
    result = EpisodeResult.model_validate_json(out)
    assert result.status.failure_kind == "agent"


@pytest.mark.slow
def test_eagc_test_exits_4_when_the_container_fails_the_contract(runs: Path) -> None:
    code, out, err = _run("test", CRASH, "--runtime", "local", "--runs-dir", str(runs))
    assert code == ExitCode.AGENT, out + err
    assert "FAIL" in out and "bad agent" in out  # the checks, and what it printed
    assert "note:" not in out and "score components" not in out  # the team's neutral card


def test_every_status_has_its_exit_code() -> None:
    """The mapping itself, for every status an episode can end with (an infrastructure
    failure cannot be provoked from the command line without breaking the machine)."""
    def result(status: EpisodeStatus) -> EpisodeResult:
        return EpisodeResult(episode="ep0", track="sanity", split="standard", image="x",
                             runtime="local", status=status, stats=EpisodeStats(),
                             score=ScoreCard(track="sanity", total=0.0, components={},
                                             weights={}), started_at=0, finished_at=0)

    for status in EpisodeStatus:
        code = _episode_exit(result(status))
        if status is EpisodeStatus.COMPLETED:
            assert code == ExitCode.OK == 0
        elif status is EpisodeStatus.INFRA_ERROR:
            assert code == ExitCode.INFRA == 3
        else:
            assert code == ExitCode.AGENT == 4
    assert ExitCode.USAGE == 2 and len({int(c) for c in ExitCode}) == len(ExitCode)


@pytest.mark.slow
def test_an_example_image_name_runs_its_agent_locally(runs: Path) -> None:
    """With --runtime local an example's image name runs that example's agent.py (it was
    passed on as a command line, which never started: agent_no_start)."""
    code, out, err = _run("run-episode", "sanity", "--runtime", "local", "--image",
                          "eagc/sanity-agent", "--runs-dir", str(runs), "--max-steps", "300")
    assert code == ExitCode.OK, out + err
    assert "completed" in out


def test_a_misspelled_demo_track_gets_a_did_you_mean() -> None:
    code, out, err = _run("demo", "--track", "trak1")
    assert code == ExitCode.USAGE
    assert "Did you mean 'track1'?" in out + err
