"""The leaderboard's order on constructed ties: the final first, then the paper's tie-breaks
in their order and direction, and a full tie shares its rank (1, 1, 3).

Track 1 (Table IV): task success, model verification, recovery, invalid actions (fewer is
better), runtime (shorter is better). Track 2 (Table VII): success, task model, attempts
(fewer), adaptation time (shorter), runtime (shorter).

The results go into a real results store by its own API, as a campaign would write them;
the leaderboard is built from the store. Every tied group is named so that the right order
is the reverse of the alphabetical one: a board that drops a tie-break (and falls back to
the team's name) or reads one in the wrong direction puts some pair the wrong way round.
"""

from __future__ import annotations

import json
import secrets
import shutil
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from orchestrator._campaign.spec import load_campaign, store_path
from orchestrator._results.leaderboard import Leaderboard, build_leaderboard
from orchestrator._results.store import EpisodeKey, ResultsStore
from schemas import EpisodeResult, EpisodeStats, EpisodeStatus, ScoreCard


@pytest.fixture()
def folder() -> Iterator[Path]:
    """A short folder (a campaign's output path is limited for the episodes' sockets)."""
    path = Path(tempfile.mkdtemp(prefix="eagc-tb-", dir="/tmp"))
    yield path
    shutil.rmtree(path, ignore_errors=True)


@dataclass(frozen=True)
class Team:
    """Two episodes of one team: their totals and successes, the rest the same in both."""

    name: str
    totals: tuple[float, float] = (0.5, 0.5)
    success: tuple[float, float] = (1.0, 0.0)
    metrics: tuple[tuple[str, float], ...] = ()
    invalid: int = 5
    wall_s: float = 600.0


def _result(track: str, team: Team, k: int) -> EpisodeResult:
    metrics = {"task_success": team.success[k], **dict(team.metrics)}
    if track == "track2":
        metrics["family_insertion"] = 1.0
    return EpisodeResult(
        episode="ep" + secrets.token_hex(8), track=track, split="standard", image="img",
        runtime="docker", status=EpisodeStatus.COMPLETED,
        score=ScoreCard(track=track, total=team.totals[k], components={}, weights={},
                        metrics=metrics),
        stats=EpisodeStats(steps=100, invalid_actions=team.invalid, wall_s=team.wall_s),
        started_at=0.0, finished_at=1.0)


def _board(folder: Path, track: str, teams: list[Team]) -> Leaderboard:
    subs = "\n".join(f"  - {{team: {t.name}, image: img}}" for t in teams)
    path = folder / "c.yaml"
    path.write_text(f"name: ties-{secrets.token_hex(3)}\ntrack: {track}\nphase: local\n"
                    "splits:\n  - {name: standard, episodes: 2}\n"
                    f"submissions:\n{subs}\noutput: {folder / 'out'}\n")
    spec = load_campaign(path)
    with ResultsStore(store_path(spec)) as store:
        store.register(spec, "c0mm1t", 2 * len(teams))
        for t in teams:
            for k in range(2):
                store.commit(spec.name, EpisodeKey(t.name, "standard", k),
                             _result(track, t, k), retry=0, node=None)
    with ResultsStore(store_path(spec)) as store:
        return build_leaderboard(spec, store)


def _order(board: Leaderboard) -> list[tuple[int, str]]:
    return [(r.rank, r.team) for r in board.rows]


def _t1(name: str, *, model: float = 0.5, recovery: float = 0.5, **kw: object) -> Team:
    return Team(name, metrics=(("model_verification", model), ("recovery", recovery)),
                **kw)  # type: ignore[arg-type]


TRACK1 = [
    # Equal finals (50) but for the first and the last; each next pair differs on one more
    # tie-break, and the better of the two is named later in the alphabet.
    _t1("zulu", totals=(0.6, 0.6), success=(0.0, 0.0), model=0.0, recovery=0.0,
        invalid=50),  # the best final wins whatever its tie-breaks
    _t1("echo", success=(1.0, 1.0), invalid=9),  # task success 100 %
    _t1("delta", model=0.9, recovery=0.0, invalid=9),  # model verification 90 %
    _t1("charlie", recovery=0.9, invalid=9),  # recovery 90 %
    _t1("bravo", invalid=1, wall_s=600.0),  # 1 invalid action per episode (alpha: 5)
    _t1("alpha", wall_s=60.0),  # 1 min (aardvark: 10 min)
    _t1("aardvark"),
    _t1("aaa", totals=(0.4, 0.4), success=(1.0, 1.0), model=1.0, recovery=1.0, invalid=0,
        wall_s=1.0),  # the worst final loses whatever its tie-breaks
]


def test_track1_ties_break_by_success_model_recovery_invalid_actions_runtime(
        folder: Path) -> None:
    board = _board(folder, "track1", TRACK1)
    finals = {r.team: r.values["final"] for r in board.rows}
    assert finals["zulu"] == pytest.approx(60.0) and finals["aaa"] == pytest.approx(40.0)
    assert {finals[t.name] for t in TRACK1[1:-1]} == {50.0}, "the middle six are tied"
    assert _order(board) == [(1, "zulu"), (2, "echo"), (3, "delta"), (4, "charlie"),
                             (5, "bravo"), (6, "alpha"), (7, "aardvark"), (8, "aaa")]


def _t2(name: str, *, model: float = 0.5, attempts: float = 2.0, adapt: float = 5.0,
        **kw: object) -> Team:
    return Team(name, metrics=(("task_model", model), ("attempts", attempts),
                               ("adapt_time_min", adapt)), **kw)  # type: ignore[arg-type]


TRACK2 = [
    _t2("zulu", totals=(0.6, 0.6), success=(0.0, 0.0), model=0.0, attempts=3.0, adapt=20.0),
    _t2("echo", success=(1.0, 1.0), attempts=3.0, adapt=10.0),  # success 100 %
    _t2("delta", model=0.9, attempts=3.0, adapt=10.0),  # task model 90 %
    _t2("charlie", attempts=1.0, adapt=10.0),  # 1 attempt (bravo: 2)
    _t2("bravo", adapt=1.0),  # adaptation 1 min (alpha: 5)
    _t2("alpha", wall_s=60.0),  # runtime 1 min (aardvark: 10)
    _t2("aardvark"),
    _t2("aaa", totals=(0.4, 0.4), success=(1.0, 1.0), model=1.0, attempts=1.0, adapt=0.0,
        wall_s=1.0),
]


def test_track2_ties_break_by_success_task_model_attempts_adaptation_runtime(
        folder: Path) -> None:
    board = _board(folder, "track2", TRACK2)
    finals = {r.team: r.values["final"] for r in board.rows}
    assert finals["zulu"] == pytest.approx(60.0) and finals["aaa"] == pytest.approx(40.0)
    assert {finals[t.name] for t in TRACK2[1:-1]} == {50.0}, "the middle six are tied"
    assert _order(board) == [(1, "zulu"), (2, "echo"), (3, "delta"), (4, "charlie"),
                             (5, "bravo"), (6, "alpha"), (7, "aardvark"), (8, "aaa")]


@pytest.mark.parametrize("track", ["track1", "track2"])
def test_a_full_tie_shares_its_rank_and_the_next_rank_is_skipped(folder: Path,
                                                                 track: str) -> None:
    make = _t1 if track == "track1" else _t2
    teams = [make("aaa", totals=(0.3, 0.3)), make("bravo"), make("charlie")]
    board = _board(folder, track, teams)
    assert _order(board) == [(1, "bravo"), (1, "charlie"), (3, "aaa")]
    doc = json.loads(board.render("json"))
    assert [(r["rank"], r["team"]) for r in doc["rows"]] == [(1, "bravo"), (1, "charlie"),
                                                            (3, "aaa")]
    # Only a full tie shares: one minute less of runtime is enough to rank alone.
    (folder / "b").mkdir()
    faster = _board(folder / "b", track, [*teams[:2], make("charlie", wall_s=540.0)])
    assert _order(faster) == [(1, "charlie"), (2, "bravo"), (3, "aaa")]
