"""Mistakes get one clear line and a documented exit code, never a traceback (issue 10 §3).

Every case runs the real ``eagc`` command (typer's test runner invokes the same app the
console script runs); none starts an episode: each must be refused before one would.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from orchestrator.cli import app
from orchestrator.cli.common import ExitCode, OneLineErrors

REPO = Path(__file__).resolve().parents[2]


def _eagc(*args: str, **env: str) -> tuple[int, str, str]:
    r = CliRunner().invoke(app, list(args), env=env or None)
    return r.exit_code, r.stdout, r.stderr


def _one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, f"expected one line, got:\n{err}"
    assert "Traceback" not in err
    assert lines[0].startswith("error: ")
    return lines[0]


@pytest.mark.parametrize("args", [
    ["run-episode", "trak1", "--image", "eagc/sanity-agent:latest"],
    ["test", "eagc/sanity-agent:latest", "--track", "trak1"],
    ["preview", "--track", "trak1"],
])
def test_misspelled_track_is_one_line_with_a_suggestion(args: list[str]) -> None:
    code, out, err = _eagc(*args)
    line = _one_error_line(err)
    assert code == ExitCode.USAGE
    assert "no track named 'trak1'. Did you mean 'track1'?" in line
    assert "sanity, track1, track2" in line


def test_sanityy_suggests_sanity() -> None:
    code, _, err = _eagc("test", "x", "--track", "sanityy")
    assert code == ExitCode.USAGE and "Did you mean 'sanity'?" in _one_error_line(err)


@pytest.mark.parametrize("args", [
    ["run-episode", "sanity", "--image", "x", "--split", "standrd"],
    ["test", "x", "--split", "standrd"],
    ["preview", "--split", "standrd"],
])
def test_unknown_split_is_refused_with_a_suggestion(args: list[str]) -> None:
    code, _, err = _eagc(*args)
    line = _one_error_line(err)
    assert code == ExitCode.USAGE
    assert "has no split 'standrd'. Did you mean 'standard'?" in line
    assert "standard, challenge" in line


def test_preview_challange_is_refused() -> None:
    code, _, err = _eagc("preview", "--split", "challange")
    assert code == ExitCode.USAGE and "Did you mean 'challenge'?" in _one_error_line(err)


@pytest.mark.parametrize("command", [["run-episode", "sanity", "--image", "x"],
                                     ["test", "x"], ["preview"]])
def test_negative_seed_is_a_usage_error(command: list[str]) -> None:
    code, _, err = _eagc(*command, "--seed", "-1")
    line = _one_error_line(err)
    assert code == ExitCode.USAGE  # not an infrastructure failure (3)
    assert "--seed" in line


def test_bad_limits_name_the_option() -> None:
    code, _, err = _eagc("run-episode", "sanity", "--image", "x", "--time-scale", "2")
    assert code == ExitCode.USAGE and "--time-scale" in _one_error_line(err)


def test_replay_and_picture_refuse_a_folder_that_is_not_an_episode(tmp_path: Path) -> None:
    code, _, err = _eagc("replay", str(tmp_path))
    assert code == ExitCode.USAGE
    assert "is not an episode folder" in _one_error_line(err)
    code, _, err = _eagc("picture", str(tmp_path))
    assert code == ExitCode.USAGE
    assert "is not an episode folder" in _one_error_line(err)
    code, _, err = _eagc("picture", str(tmp_path / "missing"))
    assert code == ExitCode.USAGE and "does not exist" in _one_error_line(err)
    text = tmp_path / "notes.txt"
    text.write_text("hello")
    code, _, err = _eagc("replay", str(text))
    assert code == ExitCode.USAGE and "is not an MCAP episode log" in _one_error_line(err)


def test_a_broken_result_file_is_one_line(tmp_path: Path) -> None:
    (tmp_path / "host").mkdir()
    (tmp_path / "host" / "result.json").write_text('{"episode": 3}')
    code, _, err = _eagc("picture", str(tmp_path))
    line = _one_error_line(err)
    assert code == ExitCode.ERROR and "result.json" in line


def test_a_campaign_file_that_does_not_validate_names_the_field(tmp_path: Path) -> None:
    path = tmp_path / "c.yaml"
    path.write_text("name: c\ntrack: trak1\nsplits: [{name: standard, episodes: 1}]\n"
                    "submissions: [{team: t, image: x}]\n")
    code, _, err = _eagc("leaderboard", str(path))
    line = _one_error_line(err)
    assert code == ExitCode.ERROR
    assert "track:" in line and "Did you mean 'track1'?" in line
    code, _, err = _eagc("status", str(tmp_path / "nothing.yaml"))
    assert code == ExitCode.ERROR and "cannot read the campaign file" in _one_error_line(err)


def test_unknown_command_and_option_are_one_line() -> None:
    code, _, err = _eagc("frobnicate")
    assert code == ExitCode.USAGE and "No such command" in _one_error_line(err)
    code, _, err = _eagc("run-episode", "sanity", "--image", "x", "--sead", "1")
    assert code == ExitCode.USAGE and "--sead" in _one_error_line(err)


def test_exit_codes_are_in_the_help_and_the_commands_page() -> None:
    _, out, _ = _eagc("run-episode", "--help", COLUMNS="200")
    assert "0 the episode completed" in out and "3 infrastructure failure" in out
    assert "4 the agent failed" in out and "2 usage" in out
    _, out, _ = _eagc("--help", COLUMNS="200")
    assert "Exit codes:" in out
    page = (REPO / "docs" / "commands.md").read_text()
    for code in ExitCode:
        assert f"| {int(code)} |" in page, f"exit code {int(code)} is not in docs/commands.md"
    assert "docs/commands.md#exit-codes" in (REPO / "README.md").read_text()


def test_an_unexpected_exception_is_one_line_and_keeps_its_traceback() -> None:
    """A bug still ends in one line; its traceback goes to a file that the line names."""
    bugged = typer.Typer(cls=OneLineErrors)

    @bugged.command()
    def boom() -> None:
        raise RuntimeError("the scorer divided by zero")

    @bugged.command()
    def other() -> None:
        pass

    r = CliRunner().invoke(bugged, ["boom"])
    line = _one_error_line(r.stderr)
    assert r.exit_code == ExitCode.ERROR
    assert "RuntimeError: the scorer divided by zero" in line
    path = Path(line.split("the traceback is in ")[1].split(";")[0])
    try:
        assert "Traceback" in path.read_text() and "divided by zero" in path.read_text()
    finally:
        path.unlink()


def test_every_command_has_a_one_line_summary_in_the_help() -> None:
    """`eagc --help` lists each command with its docstring's first paragraph on one line
    (rich kept the docstring's line breaks, cutting the listing mid-sentence)."""
    from orchestrator.cli.campaign import campaign_app

    for typer_app in (app, campaign_app):
        for info in typer_app.registered_commands:
            summary = info.short_help or info.help or ""
            assert summary and "\n" not in summary, (info.name, summary)
