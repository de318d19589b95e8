"""More of what a newcomer hit (issue 23 §2): the startup budget follows ``--time-scale``
(never below a floor a real container needs) and the spinner says what is awaited and the
time left; a frozen agent is named as such."""

from __future__ import annotations

import shutil
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace

import pytest
from typer.testing import CliRunner

from orchestrator.cli.common import STARTUP_FLOOR_S, limits_of, wait_text
from orchestrator.cli.main import app

FROZEN = Path(__file__).resolve().parents[1] / "containers" / "frozen" / "agent.py"


@pytest.fixture()
def runs() -> Iterator[Path]:
    folder = Path(tempfile.mkdtemp(prefix="eagc-nw2-", dir="/tmp"))  # short: socket paths
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def test_time_scale_scales_the_startup_budget_down_to_a_floor() -> None:
    assert limits_of(time_scale=1.0).startup_s == 120.0
    assert limits_of(time_scale=0.75).startup_s == 90.0
    assert limits_of(time_scale=0.1).startup_s == STARTUP_FLOOR_S == 60.0
    assert limits_of(time_scale=0.01).startup_s == 60.0


def test_help_says_the_startup_budget_scales() -> None:
    for cmd in (["run-episode", "--help"], ["test", "--help"]):
        out = " ".join(CliRunner().invoke(app, cmd, env={"COLUMNS": "200"}).stdout.split())
        assert "startup budget" in out and "60 s" in out, cmd


def test_spinner_says_the_wait_and_the_stage_with_time_left() -> None:
    limits = limits_of(time_scale=0.5)
    explore = SimpleNamespace(name="explore", budget_s=60.0)
    assert wait_text(5.0, limits) == "waiting for the agent's hello (55 s left)"
    assert wait_text(61.0, limits) == "the startup budget is up"
    assert wait_text(9.0, limits, explore, 12.0) == "stage explore, 18 s left"


@pytest.mark.slow
def test_the_spinner_follows_the_stages_of_the_episode(runs: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    import contextlib

    main = sys.modules["orchestrator.cli.main"]  # the package's name `main` is a function
    said: list[str] = []

    class Status:
        def update(self, text: str) -> None:
            said.append(text)

    @contextlib.contextmanager
    def status(text: str) -> Iterator[Status]:
        said.append(text)
        yield Status()

    monkeypatch.setattr(main.notes, "status", status)
    frozen = f"{sys.executable} {FROZEN}"
    r = CliRunner().invoke(app, ["run-episode", "sanity", "--runtime", "local", "--image",
                                 frozen, "--time-scale", "0.05", "--runs-dir", str(runs)])
    assert r.exit_code == 4, r.output
    assert said[0].endswith(": waiting for the agent's hello (60 s left)"), said
    assert any(": stage explore, " in t and t.endswith(" s left") for t in said), said
    assert any(": stage reach, " in t for t in said), said
    from plugins import load_track

    assert "make_episode" not in vars(load_track("sanity"))  # the plugin as it was


@pytest.mark.slow
def test_an_agent_that_never_says_hello_costs_the_scaled_startup(
        runs: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The floor lowered to 20 s here (60 s in use) to keep the test short."""
    from orchestrator.cli import common

    monkeypatch.setattr(common, "STARTUP_FLOOR_S", 20.0)
    silent = f"{sys.executable} -c 'import time; time.sleep(300)'"
    start = time.monotonic()
    r = CliRunner().invoke(app, ["run-episode", "sanity", "--runtime", "local", "--image",
                                 silent, "--time-scale", "0.1", "--runs-dir", str(runs)],
                           env={"COLUMNS": "80"})
    took = time.monotonic() - start
    assert r.exit_code == 4, r.output
    assert "startup 20 s" in r.stdout, r.stdout
    assert took < 60, took



def test_classify_names_a_silent_agent_and_not_a_busy_one() -> None:
    from orchestrator._episode.worker import _classify
    from schemas import ContainerExit, EpisodeStatus, Limits
    from simhost.host._host import EndReason, HostOutcome

    def outcome(last: float) -> HostOutcome:
        return HostOutcome(end_reason=EndReason.BUDGET, stages_reached=["explore", "reach"],
                           stage_durations_s={"explore": 6.0, "reach": 6.0},
                           last_request_at=last, ended_at=100.0)

    status, limit, msg = _classify(outcome(88.0), ContainerExit(), Limits(), [])
    assert status is EpisodeStatus.AGENT_TIMEOUT and limit == "stage budget of 'reach'"
    assert msg == "the agent sent no request for 12 s (stage 'reach' ran out of time)"
    _, _, busy = _classify(outcome(99.9), ContainerExit(), Limits(), [])
    assert busy == "the last stage 'reach' ran out of time before the agent finished"


@pytest.mark.slow
def test_a_frozen_agent_is_reported_as_silent(runs: Path) -> None:
    from orchestrator._episode.worker import EpisodeSpec, run_episode
    from orchestrator._runtimes.local import LocalProcessRuntime
    from schemas import EpisodeStatus, Limits

    result = run_episode(
        EpisodeSpec(track="sanity", image=f"{sys.executable} {FROZEN}", seed=1,
                    split="standard", runs_dir=runs, limits=Limits(time_scale=0.05)),
        LocalProcessRuntime(quiet=True))
    assert result.status is EpisodeStatus.AGENT_TIMEOUT
    assert result.failure is not None
    assert result.failure.limit_hit == "stage budget of 'reach'"
    assert result.failure.message.startswith("the agent sent no request for "), result.failure
    assert "(stage 'reach' ran out of time)" in result.failure.message


def _driver_progress(terminal: bool, name: str = "demo-track1-local") -> tuple:
    import io

    from rich.console import Console

    from orchestrator._campaign.driver import Driver

    out = io.StringIO()
    console = Console(file=out, width=80, force_terminal=terminal, color_system=None)
    me = SimpleNamespace(console=console, name=name, options=SimpleNamespace(progress=True))
    progress, bar = Driver._progress(me, 10)  # type: ignore[arg-type]
    return progress, bar, out, console


def test_piped_campaign_progress_is_a_plain_line_per_finished_episode() -> None:
    progress, bar, out, _ = _driver_progress(terminal=False)
    with progress:
        progress.update(bar, completed=0, running=2, failed=0, retries=0)
        assert out.getvalue() == ""
        progress.update(bar, completed=1, running=2, failed=0, retries=0)
        progress.update(bar, completed=3, running=1, failed=1, retries=1)
        lines = out.getvalue().splitlines()  # before the end, as it happens
    assert len(lines) == 3, lines
    assert lines[0].startswith("demo-track1-local: 1/10 episodes done · 0 failed")
    assert lines[2].startswith("demo-track1-local: 3/10 episodes done · 1 failed · 1 retried")
    assert all(len(line) <= 80 and "\x1b" not in line for line in lines)


@pytest.mark.parametrize("name", ["demo-track1-local", "a-rather-long-campaign-name-of-a-team"])
def test_the_campaign_bar_keeps_its_times_whole_in_80_columns(name: str) -> None:
    progress, bar, out, console = _driver_progress(terminal=True, name=name)
    progress.update(bar, completed=3, running=2, failed=1, retries=4)
    console.print(progress.make_tasks_table(progress.tasks))
    line, = out.getvalue().splitlines()
    assert len(line) <= 80
    assert "…" not in line.split("3/10")[1], line
    assert "1 failed · 4 retried" in line and "ETA" in line, line
