"""The finalist cut on constructed campaigns with known results: every team the data allow
within K goes through, baselines are reference rows outside the comparison, the cap is
stated and applied in the point-estimate order, and the command says who and why."""

from __future__ import annotations

import json
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from orchestrator._campaign.spec import load_campaign, store_path
from orchestrator._results.finalists import finalists
from orchestrator._results.leaderboard import Leaderboard, build_leaderboard
from orchestrator._results.store import ResultsStore
from orchestrator.cli.campaign import campaign_app
from tests.orchestrator.test_intervals import _board

#: Seven teams of known skill (success chance per episode) and a baseline among them.
SKILLS = {"atlas": 0.75, "beacon": 0.7, "cobalt": 0.62, "dune": 0.55, "ember": 0.3,
          "fjord": 0.25, "gale": 0.2, "reference": 0.65}


@pytest.fixture()
def folder() -> Iterator[Path]:
    path = Path(tempfile.mkdtemp(prefix="eagc-fi-", dir="/tmp"))
    yield path
    shutil.rmtree(path, ignore_errors=True)


def _build(path: Path, baselines: tuple[str, ...] = ()) -> Leaderboard:
    spec = load_campaign(path)
    with ResultsStore(store_path(spec)) as store:
        return build_leaderboard(spec, store, baselines=baselines)


def test_a_cut_with_overlapping_ranges_keeps_every_team_that_could_be_within_k(
        folder: Path) -> None:
    board = _build(_board(folder, 40, SKILLS, seed=5), ("reference",))
    assert board.comparison is not None and "reference" not in board.comparison.teams
    ranges = {r.team: r.rank_range for r in board.rows}
    assert ranges["reference"] is None, "a baseline has no rank range"
    assert all(r[1] <= 7 for t, r in ranges.items() if r is not None), "ranks among 7 teams"
    k = 2
    cut = finalists(board, k, baselines=("reference",))
    could = {t for t, r in ranges.items() if r is not None and r[0] <= k}
    assert len(could) > k, f"the constructed campaign should overlap at the cut: {ranges}"
    assert set(cut.finalists) == could, (cut.finalists, ranges)
    assert cut.unseparated and set(cut.unseparated) <= could
    for line in cut.lines:
        if line.verdict == "out":
            assert line.rank_range is not None and line.rank_range[0] > k, line
            assert f"best rank {line.rank_range[0]} > {k}" in line.why
    [ref] = [x for x in cut.lines if x.verdict == "reference"]
    assert ref.team == "reference" and ref.ci is not None and ref.rank_range is None
    text = cut.to_text()
    assert "IN (" in text and "OUT (" in text and "REFERENCE (1)" in text
    assert "not separated at the cut" in text
    assert all(len(line) <= 80 for line in cut.to_text(80).splitlines())


def test_more_than_the_cap_qualify_the_point_estimate_order_admits_up_to_it(
        folder: Path) -> None:
    board = _build(_board(folder, 40, SKILLS, seed=5), ("reference",))
    wide = finalists(board, 2, baselines=("reference",))
    assert len(wide.finalists) >= 3
    cut = finalists(board, 2, baselines=("reference",), cap=2)
    assert len(cut.finalists) == 2 and set(cut.finalists) < set(wide.finalists)
    order = [r.team for r in board.rows if r.team in wide.finalists]
    assert list(cut.finalists) == order[:2], "the first by the point estimate"
    assert set(cut.capped) == set(wide.finalists) - set(cut.finalists)
    for line in cut.lines:
        if line.team in cut.capped:
            assert line.verdict == "out" and "cap of 2" in line.why


def test_the_board_must_leave_the_baselines_out_of_the_comparison(folder: Path) -> None:
    board = _build(_board(folder, 40, SKILLS, seed=5))
    with pytest.raises(ValueError, match="baselines"):
        finalists(board, 2, baselines=("reference",))
    with pytest.raises(ValueError, match="not on the board"):
        finalists(board, 2, baselines=("nobody",))


def test_the_command_prints_who_is_in_who_is_out_and_why(folder: Path) -> None:
    path = _board(folder, 40, SKILLS, seed=5)
    cli = CliRunner()
    res = cli.invoke(campaign_app, ["finalists", str(path), "--k", "2",
                                    "--baseline", "reference"])
    assert res.exit_code == 0, res.output
    assert "finalists at K = 2 (cap 4)" in res.stdout and "reference" in res.stdout
    res = cli.invoke(campaign_app, ["finalists", str(path), "--k", "2", "--baseline",
                                    "reference", "--format", "json"])
    doc = json.loads(res.stdout)
    assert {r["verdict"] for r in doc["rows"]} == {"in", "out", "reference"}
    assert doc["unseparated"] and doc["cap"] == 4
    res = cli.invoke(campaign_app, ["finalists", str(path), "--k", "2", "--baseline",
                                    "refrence"])
    assert res.exit_code == 2 and "Did you mean 'reference'" in res.output
