"""``eagc check-files``: a folder checked offline as the host checks ``/output``; and the
same grouped, path-bearing lines in the score card, the contract table and ``--team``."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import pytest
from rich.console import Console
from typer.testing import CliRunner

from orchestrator._episode.agentcheck import contract_checks
from orchestrator._results.score_card import render
from orchestrator._results.team_report import _episode
from orchestrator.cli.main import app
from plugins import load_track
from schemas import EpisodeStatus, FailureReport
from tests.orchestrator.test_readable_output import _result

GOOD_MODEL = {"rooms": [{"id": 0}], "connections": [{"rooms": [0, 1]}],
              "objects": [{"id": 3, "category": "cup", "room": 0, "position": [1, 2]}]}
GOOD_LOG = '{"step": 0, "stage": "exploration", "event": "stage"}\n'


def _eagc(*args: str) -> Any:
    return CliRunner().invoke(app, ["check-files", *args], env={"COLUMNS": "80"})


def _folder(tmp_path: Path, model: Any = GOOD_MODEL, log: str | None = GOOD_LOG) -> Path:
    out = tmp_path / "output"
    out.mkdir()
    (out / "world_model.json").write_text(model if isinstance(model, str)
                                          else json.dumps(model))
    if log is not None:
        (out / "episode_log.jsonl").write_text(log)
    return out


def test_valid_files_pass_and_unknown_keys_are_listed(tmp_path: Path) -> None:
    folder = _folder(tmp_path, {**GOOD_MODEL, "agent_state": {"pose": [0, 0]}})
    r = _eagc(str(folder), "--track", "track1")
    assert r.exit_code == 0, r.output
    assert "world_model.json: ok" in r.stdout and "agent_state" in r.stdout
    assert "every file validates" in r.stdout
    assert all(len(line) <= 80 for line in r.stdout.splitlines())


def test_a_broken_file_gets_every_problem_an_example_and_its_schema(tmp_path: Path) -> None:
    model = {"agent_state": {}, "plans": [],
             "objects": [{"name": f"o{i}", "category": i} for i in range(25)],
             "doors": [{"id": i, "state": "ajar"} for i in range(25)]}
    r = _eagc(str(_folder(tmp_path, model)), "--track", "track1")
    assert r.exit_code == 1, r.output
    text = r.stdout
    lines = [x.strip() for x in text.splitlines()]
    first = next(i for i, x in enumerate(lines) if x.startswith("not graded, ignored: "))
    problems = [i for i, x in enumerate(lines) if x.startswith(("objects.", "doors."))]
    assert problems and first < min(problems), "unknown keys first"
    assert "agent_state, plans" in text
    assert "objects.*.id (objects 0-24): Field required" in text
    assert "objects.*.category (objects 0-24): Input should be a valid string" in text
    assert "doors.*.state (doors 0-24): Input should be" in text
    assert 'a valid ObjectEntry: {"id": 17' in text and 'a valid DoorState:' in text
    assert "schemas/json/world_model.json#/$defs/ObjectEntry" in text
    assert "a file does not validate" in text
    assert all(len(line) <= 80 for line in text.splitlines())


def test_a_stage_snapshot_may_lack_files_and_usage_errors_exit_2(tmp_path: Path) -> None:
    folder = _folder(tmp_path, log=None)
    assert _eagc(str(folder), "--track", "track1").exit_code == 1
    r = _eagc(str(folder), "--track", "track1", "--stage", "exploration")
    assert r.exit_code == 0, r.output and "not there" in r.stdout
    bad = _eagc(str(folder), "--track", "track1", "--stage", "explore")
    assert bad.exit_code == 2 and "Did you mean 'exploration'?" in bad.output
    assert _eagc(str(tmp_path / "none"), "--track", "track1").exit_code == 2
    assert _eagc(str(folder), "--track", "trak1").exit_code == 2


@pytest.fixture
def rejected() -> tuple:
    plugin = load_track("track1")
    model = {"objects": [{"category": "cup"}], "doors": [{"id": 1}], "extra": 1}
    _, checks = plugin.verify_files({"world_model.json": json.dumps(model).encode(),
                                     "episode_log.jsonl": GOOD_LOG.encode()})
    return tuple(checks)


def test_every_report_shows_the_same_path_bearing_lines(tmp_path: Path,
                                                        rejected: tuple) -> None:
    expected = ["not graded, ignored: extra", "doors.0.state: Field required",
                "objects.0.id: Field required"]
    folder = _folder(tmp_path, {"objects": [{"category": "cup"}], "doors": [{"id": 1}],
                                "extra": 1})
    text = _eagc(str(folder), "--track", "track1").stdout
    assert all(f"  {line}" in text for line in expected)
    # score card (team view too)
    failure = FailureReport(kind="agent", status=EpisodeStatus.AGENT_BAD_FILES,
                            stage_reached="execution",
                            message="world_model.json: doors.0.state: Field required")
    result = _result("track1", "standard", 0.0, files=rejected, failure=failure,
                     status=EpisodeStatus.AGENT_BAD_FILES, metrics={"task_success": 0.0})
    console = Console(width=120, record=True, file=io.StringIO())
    console.print(render(result, team=True))
    card = console.export_text()
    assert all(line in card for line in expected) and "more problem" not in card
    # the contract table of `eagc test`
    (files,) = [c for c in contract_checks(result) if c.name.startswith("its files")]
    assert files.detail.splitlines() == [f"world_model.json: {x}" for x in expected]
    # --team: each problem once, with its path
    team = _episode(result, 0)
    assert list(team.file_problems) == [f"world_model.json: {x}" for x in expected]
    lines = [x for x in _team_lines(team) if "Field required" in x]
    assert len(lines) == 2 and all("doors.0" in x or "objects.0" in x for x in lines)


def _team_lines(team: Any) -> list[str]:
    """The per-episode part of ``TeamReport.to_text`` for one episode."""
    from orchestrator._results.leaderboard import Row
    from orchestrator._results.team_report import TeamReport

    row = Row.__new__(Row)
    for k, v in {"values": {"final": 0.0}, "interval": None, "state": "final",
                 "rank_range": None, "rank": 1, "episodes": 1, "planned": 1}.items():
        object.__setattr__(row, k, v)
    return TeamReport("c", "track1", "local", "t", row, 1, [team]).to_text(80).splitlines()


def test_a_log_line_with_a_bad_value_is_left_out_and_named(tmp_path: Path) -> None:
    log = ('{"step": 0, "stage": "exploration", "event": "stage", "pose": [0, 0]}\n'
           '{"step": 2, "event_type": "perception", "seen": [1]}\n'
           '{"step": 4, "event_type": "recovery_failed"}\n'
           '{"step": 5, "event_type": "execution_exception", "exception_type": "door_lock"}\n'
           '{"step": 6, "event": "note"}\n')
    r = _eagc(str(_folder(tmp_path, log=log)), "--track", "track1")
    assert r.exit_code == 1, r.output
    text = r.stdout
    assert "episode_log.jsonl: 3 of 5 lines left out, not graded (lines 2-4)" in text
    assert "not graded, ignored: line 1: pose, line 2: seen" in text
    flat = " ".join(text.split())
    assert "line 2: event_type: got 'perception', not ours: write 'observation'" in flat
    assert "line 4: event_type: got 'execution_exception', not ours: write " \
           "'exception_detected'" in flat
    assert "line 3: event_type: got 'recovery_failed', not one of ours" in flat
    assert "did you mean" not in flat
    assert "exception_detected: the agent noticed an exception" in flat  # meanings listed
    assert all(len(line) <= 80 for line in text.splitlines())


def test_a_log_with_no_valid_record_fails_counting_its_lines(tmp_path: Path) -> None:
    log = "".join(json.dumps({"step": i, "event_type": "perception", "x": i}) + "\n"
                  for i in range(10))
    r = _eagc(str(_folder(tmp_path, log=log)), "--track", "track1")
    assert r.exit_code == 1, r.output
    assert "episode_log.jsonl: FAILS (all 10 lines)" in r.stdout
    assert "not graded, ignored: lines 1-10: x" in r.stdout
    assert "its schema: schemas/json/episode_log_record.json" in r.stdout


def test_the_schema_is_named_by_its_repository_path(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    r = _eagc(str(_folder(tmp_path, {"objects": [{"category": "cup"}]})), "--track", "track1")
    assert "its schema: schemas/json/world_model.json#/$defs/ObjectEntry" in r.stdout
