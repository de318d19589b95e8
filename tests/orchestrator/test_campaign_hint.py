"""The "see again" hint after a campaign (``where_results``): every line fits 80 columns
with a 30-character campaign path, each comment on a line of its own above the command
it describes, and each command it names is one the command line takes."""

from __future__ import annotations

import shlex
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from orchestrator._campaign.spec import load_campaign
from orchestrator.cli.campaign import where_results
from orchestrator.cli.main import app

#: A campaign file's path as a team writes it, 30 characters.
SOURCE = "campaigns/team_alpha_dev6.yaml"


@pytest.fixture()
def source(monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    folder = Path(tempfile.mkdtemp(prefix="eagc-hint-", dir="/tmp"))  # short: sockets
    monkeypatch.chdir(folder)
    path = Path(SOURCE)
    path.parent.mkdir()
    doc = {"name": "team-alpha-dev", "track": "sanity", "phase": "local",
           "runtime": "local", "splits": [{"name": "standard", "weight": 1.0,
                                           "episodes": 1}],
           "submissions": [{"team": "team-alpha", "image": "python agent.py"}],
           "output": "out"}
    path.write_text(yaml.safe_dump(doc))
    yield path
    shutil.rmtree(folder, ignore_errors=True)


def _see_again(lines: list[str]) -> list[str]:
    return lines[lines.index("see again:") + 1:]


def test_the_hint_fits_80_columns_with_a_30_character_path(source: Path) -> None:
    assert len(str(source)) == 30
    lines = where_results(load_campaign(source), source)
    too_wide = [line for line in lines if len(line) > 80]
    assert not too_wide, too_wide
    hint = _see_again(lines)
    assert "  eagc leaderboard campaigns/team_alpha_dev6.yaml --team NAME" in hint
    for k, line in enumerate(hint):
        assert line.startswith("  "), line
        if line.lstrip().startswith("#"):
            # a comment stands alone and describes the command under it
            assert k + 1 < len(hint) and hint[k + 1].lstrip().startswith("eagc "), hint
        else:
            assert line.lstrip().startswith("eagc ") and "#" not in line, line
            assert "(" not in line, line  # no comment trailing a command


def test_each_command_of_the_hint_is_one_the_command_line_takes(source: Path) -> None:
    """Run as printed (``NAME`` a team's name): each reads the campaign, none is a usage
    error; with no episode run yet they say so (exit 1), or show the empty board (0)."""
    commands = [shlex.split(line)[1:] for line in _see_again(
        where_results(load_campaign(source), source)) if not line.lstrip().startswith("#")]
    assert [c[0] for c in commands] == ["leaderboard", "status", "leaderboard", "report"]
    runner = CliRunner()
    for args in commands:
        args = ["team-alpha" if a == "NAME" else a for a in args]
        got = runner.invoke(app, args)
        assert got.exit_code in (0, 1), (args, got.output)
        assert "Usage:" not in got.output and "No such" not in got.output, (args, got.output)
