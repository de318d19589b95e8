"""What a newcomer hit with ``eagc test`` and the failure messages (issue 23 §2).

A crash 0.8 s in is reported as a crash, on one failing line, with a one-line verdict; a
misspelled image is one line with "Did you mean"; a command with the Docker runtime is a
usage error, not an infrastructure failure.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from typer.testing import CliRunner

from orchestrator.cli.common import ExitCode
from orchestrator.cli.main import app

CRASH_AT_08 = (f"{sys.executable} -c 'import sys, time; print(\"loading the model\"); "
               "time.sleep(0.8); print(\"boom: no weights\"); sys.exit(7)'")


@pytest.fixture()
def runs() -> Iterator[Path]:
    folder = Path(tempfile.mkdtemp(prefix="eagc-nw-", dir="/tmp"))  # short: socket paths
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def _run(*args: str) -> tuple[int, str, str]:
    r = CliRunner().invoke(app, list(args), env={"COLUMNS": "80"})
    return r.exit_code, r.stdout, r.stderr


@pytest.mark.slow
def test_an_agent_that_crashes_early_is_reported_as_a_crash_on_one_line(runs: Path) -> None:
    code, out, err = _run("test", CRASH_AT_08, "--runtime", "local", "--runs-dir", str(runs))
    assert code == ExitCode.AGENT, out + err
    assert "no reset arrived" not in out
    assert out.count("FAIL") == 1, out  # one cause, one failing line
    assert "exit code 7" in out and "boom: no weights" in out
    verdicts = [line for line in out.splitlines() if line.startswith("verdict:")]
    assert len(verdicts) == 1 and "agent_crash" in verdicts[0], out
    assert all(len(line) <= 80 for line in out.splitlines()), out


class _NotFoundImages:
    def __init__(self, tags: list[str]) -> None:
        self.tags = tags

    def get(self, name: str) -> Any:
        import docker

        raise docker.errors.ImageNotFound(f"no such image: {name}")

    def list(self) -> list[Any]:
        return [SimpleNamespace(tags=[t]) for t in self.tags]


class _FakeDockerRuntime:
    name = "docker"

    def __init__(self, *_: Any, **__: Any) -> None:
        self.client = SimpleNamespace(images=_NotFoundImages(
            ["eagc/sanity-agent:latest", "eagc/track1-heuristic:latest", "other/x:1"]))

    def start(self, launch: Any) -> Any:  # pragma: no cover - never reached
        raise AssertionError("the episode must not start")


def test_a_misspelled_image_is_one_line_with_did_you_mean(
        runs: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import orchestrator._runtimes.docker as docker_runtime

    monkeypatch.setattr(docker_runtime, "DockerRuntime", _FakeDockerRuntime)
    code, out, err = _run("test", "eagc/sanity-agnt", "--runs-dir", str(runs))
    assert code == ExitCode.USAGE, out + err
    assert out == "" and len(err.strip().splitlines()) == 1, out + err
    assert "Did you mean 'eagc/sanity-agent'?" in err and len(err.strip()) <= 80, err
    assert "exit code None" not in out + err


def test_a_command_with_the_docker_runtime_is_a_usage_error(runs: Path) -> None:
    code, out, err = _run("test", "python agent.py", "--runs-dir", str(runs))
    assert code == ExitCode.USAGE, out + err
    assert len(err.strip().splitlines()) == 1 and "--runtime local" in err, err
    assert "Traceback" not in out + err and "infra" not in out + err
    assert len(err.strip()) <= 80


def test_an_agent_that_exits_0_too_soon_is_not_said_to_have_crashed() -> None:
    from orchestrator._episode.worker import _classify
    from schemas import ContainerExit, EpisodeStatus, Limits
    from simhost.host._host import EndReason, HostOutcome

    outcome = HostOutcome(end_reason=EndReason.STOPPED, stages_reached=["explore", "reach"])
    status, _, message = _classify(outcome, ContainerExit(exit_code=0), Limits(), [])
    assert status is EpisodeStatus.AGENT_CRASH  # the status a script sees stays the same
    assert message == "the agent exited with code 0 before the episode ended, during 'reach'"
    _, _, crashed = _classify(outcome, ContainerExit(exit_code=7), Limits(), [])
    assert "exit code 7" in crashed


@pytest.mark.slow
def test_a_clean_early_exit_says_so_on_the_card(runs: Path) -> None:
    code, out, err = _run("run-episode", "sanity", "--runtime", "local", "--image",
                          f"{sys.executable} -c pass", "--runs-dir", str(runs))
    assert code == ExitCode.AGENT, out + err
    assert "exited with code 0 before the episode ended" in " ".join(out.split()), out


def test_the_leaderboard_title_names_the_phase_as_a_phase() -> None:
    """"local" is both a campaign phase and the no-sandbox runtime: the title says which."""
    from orchestrator._results.leaderboard import Column, Leaderboard

    board = Leaderboard("demo-sanity", "sanity", "local", [Column("final", "Final")], [])
    assert board.to_text(80).splitlines()[0].startswith("demo-sanity · sanity · phase local")
    assert board.to_markdown().splitlines()[0] == "## demo-sanity (sanity, phase local)"
