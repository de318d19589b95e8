"""``eagc preview`` names its file by one scheme for every track (issue 23 §2):
``<track>-<split>-seed<N>.png`` in the folder asked for, and nothing else left there."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from orchestrator.cli.common import ExitCode
from orchestrator.cli.main import app, preview_name


@pytest.mark.parametrize(("track", "split"), [("track1", "challenge"), ("track2", "standard")])
def test_every_tracks_preview_has_the_same_name_scheme(tmp_path: Path, track: str,
                                                       split: str) -> None:
    out = tmp_path / "previews"
    r = CliRunner().invoke(app, ["preview", "--track", track, "--split", split,
                                 "--seed", "7", "--out", str(out)], env={"COLUMNS": "200"})
    assert r.exit_code == 0, r.stdout + r.stderr
    expected = out / f"{track}-{split}-seed7.png"
    assert expected.name == preview_name(track, split, 7)
    assert [p.name for p in out.iterdir()] == [expected.name]
    assert expected.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert str(expected) in r.stdout  # the path it names is the file written


def test_a_track_without_previews_is_one_line_and_leaves_nothing(tmp_path: Path) -> None:
    out = tmp_path / "previews"
    r = CliRunner().invoke(app, ["preview", "--track", "sanity", "--out", str(out)])
    assert r.exit_code == ExitCode.USAGE, r.stdout + r.stderr
    assert "no scenario previews" in r.stderr
    assert not any(out.iterdir())
