"""Output a person can read (issue 10 §2): leaderboards within $COLUMNS, exact numbers,
score cards that name a file's actual problem, a team's own report, retries told as the
campaign set them.

The results are written to a real results store (SQLite) by the store's own API, as a
campaign would; the commands are the real ``eagc`` CLI. The episodes' contents are made
here (no episode runs), so that each test controls exactly what the output must show.
"""

from __future__ import annotations

import io
import json
import secrets
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from orchestrator._campaign.spec import load_campaign, store_path
from orchestrator._results.score_card import render
from orchestrator._results.store import EpisodeKey, ResultsStore
from orchestrator.cli import app
from plugins import load_track
from schemas import (
    ContainerExit,
    EpisodeResult,
    EpisodeStats,
    EpisodeStatus,
    FailureReport,
    FileCheck,
    ScoreCard,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TEAMS = ("track2_demoparser", "track2_waypoint", "a_team_with_a_rather_long_name_2026")


def _result(track: str, split: str, total: float, *, status: EpisodeStatus =
            EpisodeStatus.COMPLETED, latency: float = 0.37, episode_dir: Path | None = None,
            files: tuple[FileCheck, ...] = (), notes: tuple[str, ...] = (),
            weights: dict[str, float] | None = None, failure: FailureReport | None = None,
            metrics: dict[str, float] | None = None) -> EpisodeResult:
    plugin = load_track(track)
    return EpisodeResult(
        episode="ep" + secrets.token_hex(8), track=track, split=split, image="img",
        runtime="docker", status=status,
        score=ScoreCard(track=track, total=total, components={k: total for k in plugin.weights},
                        weights=weights or dict(plugin.weights), notes=notes,
                        metrics=metrics or {"task_success": 1.0, "family_insertion": 1.0}),
        stats=EpisodeStats(steps=120, latency_ms_median=latency, latency_ms_p99=2 * latency,
                           peak_memory_bytes=50 << 20, wall_s=3.0),
        files=files, stages_reached=("demonstration", "parsing", "execution"),
        failure=failure, container=ContainerExit(exit_code=0),
        episode_dir=None if episode_dir is None else str(episode_dir),
        started_at=0.0, finished_at=3.0)


def _campaign(tmp_path: Path, track: str = "track2", retries: int = 0) -> Path:
    subs = "\n".join(f"  - {{team: {t}, image: img}}" for t in TEAMS)
    path = tmp_path / "c.yaml"
    path.write_text(f"name: board\ntrack: {track}\nphase: local\nretries: {retries}\n"
                    "splits:\n  - {name: standard, weight: 0.5, episodes: 2}\n"
                    "  - {name: challenge, weight: 0.5, episodes: 1}\n"
                    f"submissions:\n{subs}\noutput: {tmp_path / 'out'}\n")
    return path


@pytest.fixture()
def short_dir() -> Iterator[Path]:
    """A short folder (a campaign's output must leave room for unix socket paths)."""
    folder = Path(tempfile.mkdtemp(prefix="eagc-ro-", dir="/tmp"))
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture()
def board(short_dir: Path) -> Path:
    """Track 2's three teams: one full, one with an agent failure, one with a quarantine."""
    tmp_path = short_dir
    path = _campaign(tmp_path)
    spec = load_campaign(path)
    ep = tmp_path / "out" / "board" / "ep1"
    (ep / "host").mkdir(parents=True)
    (ep / "host" / "agent.log").write_text("loading demo\nstep 10\nKeyError: 'goal'\n")
    bad = FileCheck(name="task_model.json", ok=False, size=12,
                    reason="task_model.json: version: Input should be 'eagc-task-model/v1'\n"
                           "  - version: Input should be 'eagc-task-model/v1'")
    crash = FailureReport(kind="agent", status=EpisodeStatus.AGENT_CRASH,
                          stage_reached="execution", limit_hit=None, exit_code=1,
                          message="the agent exited (exit code 1) before the episode ended")
    with ResultsStore(store_path(spec)) as store:
        store.register(spec, "c0mm1t", 9)
        a, b, c = TEAMS
        for i, (split, total) in enumerate([("standard", 0.97), ("standard", 0.99),
                                            ("challenge", 0.95)]):
            store.commit("board", EpisodeKey(a, split, i if split == "standard" else 0),
                         _result("track2", split, total), retry=0, node=None)
        store.commit("board", EpisodeKey(b, "standard", 0),
                     _result("track2", "standard", 0.25), retry=0, node=None)
        store.commit("board", EpisodeKey(b, "standard", 1), _result(
            "track2", "standard", 0.1, status=EpisodeStatus.AGENT_CRASH, episode_dir=ep,
            files=(bad,), failure=crash, notes=("family=insertion",)), retry=0, node=None)
        store.commit("board", EpisodeKey(b, "challenge", 0),
                     _result("track2", "challenge", 0.3), retry=0, node=None)
        store.commit("board", EpisodeKey(c, "standard", 0),
                     _result("track2", "standard", 0.5), retry=0, node=None)
        store.commit("board", EpisodeKey(c, "standard", 1),
                     _result("track2", "standard", 0.5), retry=0, node=None)
        store.quarantine("board", EpisodeKey(c, "challenge", 0), episode="ep9",
                         message="engine error", retries=0)
    return path


def _eagc(*args: str, columns: int | None = 80) -> Any:
    env = {"COLUMNS": str(columns)} if columns else {}
    return CliRunner().invoke(app, list(args), env=env)


@pytest.mark.parametrize("columns", [80, 60, 100, 160, 40])
def test_the_leaderboard_fits_the_width_without_cutting_names_or_scores(
        board: Path, columns: int) -> None:
    r = _eagc("leaderboard", str(board), columns=columns)
    assert r.exit_code == 0, r.output
    lines = r.stdout.splitlines()
    too_wide = [ln for ln in lines if len(ln) > columns]
    assert not too_wide, too_wide
    doc = json.loads(_eagc("leaderboard", str(board), "--format", "json").stdout)
    for row in doc["rows"]:
        assert row["team"] in r.stdout  # whole, never "track2…"
        assert f"{row['values']['final']:.1f}" in r.stdout
    assert "…" not in r.stdout


def test_columns_is_honoured_when_piped(board: Path) -> None:
    """The test runner's stdout is not a terminal: $COLUMNS decides, not a fixed 160."""
    wide = _eagc("leaderboard", str(board), columns=200).stdout
    narrow = _eagc("leaderboard", str(board), columns=80).stdout
    assert max(map(len, wide.splitlines())) > 80 >= max(map(len, narrow.splitlines()))


def test_json_keeps_its_fields_on_a_0_100_scale(board: Path) -> None:
    doc = json.loads(_eagc("leaderboard", str(board), "--format", "json").stdout)
    rows = {r["team"]: r for r in doc["rows"]}
    assert set(rows) == set(TEAMS)
    first = rows[TEAMS[0]]
    assert first["episodes"] == 3 and first["planned"] == 3
    # Eq. (2) with the campaign's weights: 0.5 standard + 0.5 challenge, 0-100.
    assert first["values"]["final"] == pytest.approx(50 * (0.97 + 0.99) / 2 + 50 * 0.95)
    assert rows[TEAMS[2]]["state"] == "pending"


def test_small_values_and_weights_read_as_they_are(board: Path) -> None:
    text = _eagc("leaderboard", str(board), columns=200).stdout
    row = next(ln for ln in text.splitlines() if TEAMS[0] in ln)
    assert " 0.05 " in row  # runtime 3 s = 0.05 min, not "0.1" ({:.1f}) nor "0"
    card = _result("track2", "standard", 0.5, latency=0.37,
                   weights={"success": 0.125, "adaptation": 0.375, "generalization": 0.25,
                            "task_model": 0.125, "stability": 0.125})
    from rich.console import Console

    console = Console(width=100, record=True, file=io.StringIO())
    console.print(render(card))
    shown = console.export_text()
    assert "0.37 ms median" in shown and "0.74 ms p99" in shown
    assert "0.125" in shown and "0.375" in shown and "0.12 " not in shown


def test_a_rejected_file_names_its_actual_problem() -> None:
    """Through the track's own check of a real file, to the score card."""
    plugin = load_track("track1")
    _, checks = plugin.verify_files({
        "world_model.json": b'{"version": "eagc-world-model/v0"}',
        "episode_log.jsonl": b"",
    })
    by_name = {c.name: c for c in checks}
    result = _result("track1", "standard", 0.1, files=tuple(checks),
                     metrics={"task_success": 0.0})
    from rich.console import Console

    console = Console(width=120, record=True, file=io.StringIO())
    console.print(render(result))
    shown = console.export_text()
    assert "version: Input should be 'eagc-world-model/v1'" in shown
    assert "problem(s)" not in shown
    assert not by_name["episode_log.jsonl"].ok and "empty" in shown


def test_the_team_report_shows_its_own_episodes_only(board: Path) -> None:
    r = _eagc("leaderboard", str(board), "--team", TEAMS[1])
    assert r.exit_code == 0, r.output
    text = r.stdout
    assert all(len(ln) <= 80 for ln in text.splitlines())
    assert f"{TEAMS[1]} in board" in text and "rank 3 of 3" in text
    for where in ("standard/0", "standard/1", "challenge/0"):
        assert where in text
    assert "agent_crash" in text and "execution" in text
    assert "version: Input should be 'eagc-task-model/v1'" in text
    assert "KeyError: 'goal'" in text  # the tail of its own agent.log
    assert TEAMS[0] not in text and TEAMS[2] not in text and "engine error" not in text
    assert "family=" not in text and "weight" not in text  # nothing of the scenario
    assert str(board.parent) not in text  # no organizer path

    doc = json.loads(_eagc("leaderboard", str(board), "--team", TEAMS[1], "--format",
                           "json").stdout)
    assert doc["team"] == TEAMS[1] and len(doc["episode_reports"]) == 3
    assert "KeyError" in doc["episode_reports"][1]["agent_output"]

    r = _eagc("leaderboard", str(board), "--team", "track2_waypont")
    assert r.exit_code == 2 and "Did you mean 'track2_waypoint'?" in r.stderr


def test_quarantine_lines_agree_with_the_campaigns_retries(board: Path) -> None:
    text = _eagc("leaderboard", str(board), columns=200).stdout
    assert "not retried (the campaign allows 0)" in text
    assert "retried and held back" not in text
    status = _eagc("status", str(board), columns=200).stdout
    assert "not retried (the campaign allows 0)" in status
    assert "0 allowed" in status
    team = _eagc("leaderboard", str(board), "--team", TEAMS[2], columns=200).stdout
    assert "quarantined" in team and "not retried" in team


def _splits_played(folder: Path) -> set[str] | None:
    """The splits an example image says it plays (``LABEL eagc.splits="a,b"`` in its
    Dockerfile); None: every split."""
    for line in (folder / "Dockerfile").read_text().splitlines():
        if line.startswith("LABEL eagc.splits="):
            return set(line.split("=", 1)[1].strip('"').split(","))
    return None


def test_every_example_agent_is_in_its_tracks_demo() -> None:
    """Adding a baseline to the demo is adding its image to the demo file: this keeps
    the files in step with examples/ (every example agent of a track is in its demo, but
    one that plays only splits the demo does not: the vision baseline)."""
    from orchestrator._images.build import example_agents
    from orchestrator.cli.demo import demo_files

    files = demo_files()
    assert set(files) == {"sanity", "track1", "track2"}
    for track, path in files.items():
        spec = load_campaign(path)
        assert spec.track == track and spec.secret is None and spec.phase == "local"
        images = {s.image for s in spec.submissions}
        demo_splits = {s.name for s in spec.splits}
        plays = {tag: _splits_played(folder) for tag, folder in example_agents().items()
                 if folder.name.startswith(f"{track}_")}
        mine = {tag for tag, splits in plays.items() if splits is None or splits & demo_splits}
        assert mine <= images, f"{path.name} lacks {sorted(mine - images)}"
        assert not (set(plays) - mine) & images, "an image in a demo that plays none of it"
        assert spec.limits.max_steps_per_stage is not None  # outcomes independent of speed
    assert _splits_played(EXAMPLES / "track1_vision") == {"vision"}


def test_the_contract_check_names_the_files_problem_once() -> None:
    from orchestrator._episode.agentcheck import contract_checks

    plugin = load_track("sanity")
    _, checks = plugin.verify_files({"world_model.json": b'{"objects": 3}',
                                     "episode_log.jsonl": b'{"step": 0, "event": "note"}\n'})
    result = _result("sanity", "standard", 0.2, files=tuple(checks),
                     metrics={"task_success": 0.0})
    (files,) = [c for c in contract_checks(result) if c.name.startswith("its files")]
    assert not files.ok
    assert files.detail == "world_model.json: objects: Input should be a valid list"
