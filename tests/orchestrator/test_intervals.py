"""Intervals and rank ranges, checked against simulations with known answers.

Per-episode scores are drawn like the measured ones: bimodal, about 90 when the task is
done and 10-30 when not, the chance of success varying by episode (the same hidden seed is
hard for every team: episodes are paired). The true mean of a team is known from the
distribution, so coverage, power and false separations can be counted.
"""

from __future__ import annotations

import json
import secrets
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from orchestrator._campaign.spec import load_campaign, store_path
from orchestrator._results import intervals as iv
from orchestrator._results.leaderboard import build_leaderboard
from orchestrator._results.store import EpisodeKey, ResultsStore
from schemas import EpisodeResult, EpisodeStats, EpisodeStatus, ScoreCard

WEIGHTS = {"standard": 0.6, "challenge": 0.4}


def _scores(p: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Bimodal scores (0-100): success with probability ``p`` (per episode)."""
    hit = rng.random(p.shape) < p
    return np.clip(np.where(hit, rng.normal(90, 6, p.shape), rng.normal(20, 9, p.shape)),
                   0, 100)


def _true_mean(p: float) -> float:
    """The exact mean of ``_scores`` at success probability ``p`` (by a large sample)."""
    return float(_scores(np.full(2_000_000, p), np.random.default_rng(0)).mean())


def _campaign(skill: list[float], n: int, rng: np.random.Generator) -> np.ndarray:
    """teams × (n standard + n challenge) paired scores: one difficulty per episode (a
    logit shift shared by every team), each team's success chance from its skill."""
    shift = rng.normal(0.0, 1.0, 2 * n)
    logit = np.log(np.array(skill) / (1 - np.array(skill)))[:, None] + shift[None]
    return _scores(1 / (1 + np.exp(-logit)), rng)


def _design(n: int) -> tuple[list[iv.Cell], np.ndarray]:
    return iv.split_cells([("standard", "")] * n + [("challenge", "")] * n, WEIGHTS)


def test_intervals_cover_the_true_final_in_93_to_97_percent_of_campaigns() -> None:
    """1,000 campaigns of 20 + 20 episodes of one team (success 35 % standard, 20 %
    challenge, independent episodes): its 95 % interval holds the true eq. 2 final."""
    rng = np.random.default_rng(7)
    truth = WEIGHTS["standard"] * _true_mean(0.35) + WEIGHTS["challenge"] * _true_mean(0.2)
    cells, strata = _design(20)
    p = np.array([0.35] * 20 + [0.2] * 20)
    covered = 0
    for _ in range(1000):
        x = _scores(p, rng)[None]
        got = iv.interval(x, np.ones_like(x, dtype=bool), cells,
                          iv.resample_counts(strata, 1000, rng))[0]
        assert got is not None and got.low <= got.value <= got.high
        covered += got.low <= truth <= got.high
    assert 930 <= covered <= 970, f"coverage {covered / 10:.1f} %"


def test_two_teams_20_points_apart_separate_on_80_80_not_on_5_5() -> None:
    rng = np.random.default_rng(11)
    gap = _true_mean(0.5) - _true_mean(0.22)
    assert 18 < gap < 22
    outcome = {}
    for n in (80, 5):
        cells, strata = _design(n)
        separated = 0
        for _ in range(100):
            x = _campaign([0.5, 0.22], n, rng)
            c = iv.compare(["a", "b"], x, np.ones_like(x, dtype=bool), cells,
                           iv.resample_counts(strata, 2000, rng))
            separated += c.rank_range("a") == (1, 1) and c.rank_range("b") == (2, 2)
        outcome[n] = separated
    assert outcome[80] >= 95, outcome
    assert outcome[5] <= 30, outcome  # overlapping ranges in at least 70 of 100


def test_twenty_equal_teams_are_not_separated_in_90_percent_of_campaigns() -> None:
    """The family-wise error of the default (max-t step-down) comparison: measured 11 of
    200 campaigns here (Holm on the same resamples and expansion: 7)."""
    rng = np.random.default_rng(13)
    cells, strata = _design(20)
    falsely = 0
    for _ in range(200):
        x = _campaign([0.3] * 20, 20, rng)
        c = iv.compare([f"t{i}" for i in range(20)], x, np.ones_like(x, dtype=bool), cells,
                       iv.resample_counts(strata, 500, rng))
        falsely += bool(c.beats.any())
        assert all(c.rank_range(t)[0] <= c.rank_range(t)[1] for t in c.teams)
    assert falsely <= 20, f"{falsely} of 200 campaigns separated two equal teams"


EIGHT = [0.7, 0.6, 0.55, 0.5, 0.4, 0.35, 0.3, 0.2]


def _separations(n: int, campaigns: int, seed: int) -> dict[str, tuple[int, int]]:
    """(true gaps separated, wrong-way separations) of eight teams of known skills over
    ``campaigns`` campaigns of n + n episodes, Holm and max-t on the same resamples."""
    rng = np.random.default_rng(seed)
    cells, strata = _design(n)
    truth = np.array(EIGHT)[:, None] > np.array(EIGHT)[None, :]
    got = {"holm": [0, 0], "max-t": [0, 0]}
    for _ in range(campaigns):
        x = _campaign(EIGHT, n, rng)
        counts = iv.resample_counts(strata, 500, rng)
        for method, tally in got.items():
            c = iv.compare([f"t{i}" for i in range(8)], x, np.ones_like(x, dtype=bool), cells,
                           counts, method=method)  # type: ignore[arg-type]
            tally[0] += int((c.beats & truth).sum())
            tally[1] += int((c.beats & ~truth).sum())
    return {m: (a, b) for m, (a, b) in got.items()}


def test_max_t_separates_at_least_as_many_true_gaps_as_holm_on_10_10_and_80_80() -> None:
    """Eight teams of known skills (success 20-70 %, gaps of 2-25 points), 100 campaigns
    each, both methods on the same resamples and the same small-sample expansion (Holm's
    p-values are ``pair_p``): the max-t step-down separates at least as many true gaps as
    Holm on 10 + 10 and on 80 + 80 (measured 177 against 134, 1502 against 1464 of
    2800), and neither separates a pair the wrong way more than once in a hundred
    campaigns."""
    for n, seed in ((10, 43), (80, 41)):
        got = _separations(n, 100, seed)
        assert got["max-t"][0] >= got["holm"][0], (n, got)
        assert got["max-t"][1] <= max(1, got["holm"][1]), (n, got)


def test_a_pairs_p_value_is_the_inverse_of_the_expanded_critical_value() -> None:
    """Holm and the max-t expand alike: a pair is beyond the expanded normal quantile of
    tail a / 2 exactly when its p-value is below a, on few episodes and on many; with
    two teams both are the plain paired test at 95 %."""
    n, k = np.array([12, 20, 160, 1]), np.array([2, 2, 2, 1])
    for a in (0.05, 0.05 / 28, 1e-4):
        crit = iv.expanded_critical(float(iv.stats.norm.isf(a / 2)), n, k)
        assert np.allclose(iv.pair_p(crit, n, k), a)
        assert np.all(iv.pair_p(crit * 1.01, n, k) < a)
    wide = iv.widening(20, 2, 0.95) * iv.stats.norm.isf(0.025)
    assert np.isclose(iv.pair_p(np.array([wide]), np.array([20]), np.array([2]))[0], 0.05)


def test_a_team_ahead_on_every_shared_episode_beats_one_with_extra_episodes() -> None:
    """Pairs are compared on the episodes both have: the extra (high) episodes of b do
    not count against a."""
    cells, strata = _design(30)
    rng = np.random.default_rng(3)
    b = _campaign([0.3], 30, rng)[0]
    a = np.clip(b + 30, 0, 100)
    x = np.stack([a, np.where(np.arange(60) < 50, b, 100.0)])
    present = np.ones_like(x, dtype=bool)
    present[0, 50:] = False  # a lacks the last ten challenge episodes; b aced them
    c = iv.compare(["a", "b"], x, present, cells, iv.resample_counts(strata, 1000, rng))
    assert c.rank_range("a") == (1, 1) and c.beats[0, 1]


# ------------------------------------------------------------ on the leaderboard
@pytest.fixture()
def folder() -> Iterator[Path]:
    path = Path(tempfile.mkdtemp(prefix="eagc-iv-", dir="/tmp"))
    yield path
    shutil.rmtree(path, ignore_errors=True)


def _result(split: str, total: float, success: bool) -> EpisodeResult:
    return EpisodeResult(
        episode="ep" + secrets.token_hex(8), track="track1", split=split, image="img",
        runtime="docker", status=EpisodeStatus.COMPLETED,
        score=ScoreCard(track="track1", total=total, components={}, weights={},
                        metrics={"task_success": float(success),
                                 "model_verification": 0.5}),
        stats=EpisodeStats(steps=10, wall_s=1.0), started_at=0.0, finished_at=1.0)


def _board(folder: Path, n: int, skills: dict[str, float], seed: int) -> Path:
    teams = "\n".join(f"  - {{team: {t}, image: img}}" for t in skills)
    path = folder / f"c{n}.yaml"
    path.write_text(f"name: iv-{n}-{seed}\ntrack: track1\nphase: local\nsplits:\n"
                    f"  - {{name: standard, episodes: {n}}}\n"
                    f"  - {{name: challenge, episodes: {n}}}\n"
                    f"submissions:\n{teams}\noutput: {folder / 'out'}\n")
    spec = load_campaign(path)
    x = _campaign(list(skills.values()), n, np.random.default_rng(seed))
    with ResultsStore(store_path(spec)) as store:
        store.register(spec, "c0mm1t", 9)
        for t, team in enumerate(skills):
            for e in range(2 * n):
                split, index = ("standard", e) if e < n else ("challenge", e - n)
                store.commit(spec.name, EpisodeKey(team, split, index),
                             _result(split, x[t, e] / 100, x[t, e] > 60), retry=0, node=None)
    return path


def _leaderboard(path: Path):  # noqa: ANN202 - a Leaderboard
    spec = load_campaign(path)
    with ResultsStore(store_path(spec)) as store:
        return build_leaderboard(spec, store)


SKILLS = {"structured": 0.5, "lookahead": 0.4, "heuristic": 0.22, "memoryfree": 0.2}


def test_the_leaderboard_prints_overlapping_ranges_on_10_10_and_separates_on_80_80(
        folder: Path) -> None:
    small = _leaderboard(_board(folder, 10, SKILLS, seed=1))
    ranges = {r.team: r.rank_range for r in small.rows}
    assert all(r is not None for r in ranges.values())
    best, worst = ranges["structured"]  # type: ignore[misc]
    assert worst > 1, f"10 + 10 episodes should not settle first place: {ranges}"
    big = _leaderboard(_board(folder, 80, SKILLS, seed=2))
    ranges = {r.team: r.rank_range for r in big.rows}
    assert ranges["structured"][1] < ranges["heuristic"][0], ranges  # type: ignore[index]
    for row in big.rows:
        assert row.interval is not None
        assert row.interval.low <= row.values["final"] <= row.interval.high  # type: ignore
        assert row.interval.value == pytest.approx(row.values["final"])
        for key in ("standard", "challenge", "task_success", "model_verification"):
            got = row.intervals[key]
            assert got.low <= row.values[key] <= got.high  # type: ignore[operator]
        assert "recovery" not in row.intervals  # no episode carries it here


def test_every_format_carries_intervals_and_ranges_and_they_repeat(folder: Path) -> None:
    path = _board(folder, 10, SKILLS, seed=4)
    board = _leaderboard(path)
    again = _leaderboard(path)
    assert [(r.interval, r.rank_range) for r in board.rows] == \
        [(r.interval, r.rank_range) for r in again.rows], "the same store, the same intervals"
    doc = json.loads(board.render("json"))
    for row in doc["rows"]:
        assert row["ci_low"] <= row["values"]["final"] <= row["ci_high"]
        best, worst = row["rank_range"]
        assert 1 <= best <= row["rank"] <= worst <= 4
        assert set(row["intervals"]) >= {"standard", "challenge", "task_success"}
    csv = board.render("csv").splitlines()
    assert {"rank_best", "rank_worst", "ci_low", "ci_high", "standard_low"} <= \
        set(csv[0].split(","))
    md = board.render("md")
    assert "| Ranks |" in md and "95% CI" in md
    text = board.render("table", 80)
    assert all(len(line) <= 80 for line in text.splitlines())
    for r in board.rows:
        assert r.ranks in text and r.ci in text
