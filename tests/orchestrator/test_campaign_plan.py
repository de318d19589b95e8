"""``eagc campaign plan``: its answer checked against simulated campaigns of that size.

Two teams whose per-episode paired difference has a known spread and a known mean (the
gap) play the planned number of episodes; the leaderboard's own paired bootstrap must
separate them about as often as the plan promises (its power), and much less often on a
quarter of the episodes.
"""

from __future__ import annotations

import json
import math
import secrets
import shutil
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from orchestrator._campaign.plan import episodes_needed
from orchestrator._campaign.spec import load_campaign, store_path
from orchestrator._results import intervals as iv
from orchestrator._results.store import EpisodeKey, ResultsStore
from orchestrator.cli import app
from schemas import EpisodeResult, EpisodeStats, EpisodeStatus, ScoreCard

WEIGHTS = {"standard": 0.6, "challenge": 0.4}
SPREAD = {"standard": 34.0, "challenge": 30.0}


def _separation(episodes: Mapping[str, int], gap: float, campaigns: int,
                rng: np.random.Generator) -> float:
    """Share of simulated two-team campaigns the leaderboard's bootstrap separates. Each
    paired difference is +-a (bimodal, as a task done by one team and not the other), the
    sign's odds set so that its mean is ``gap`` and its spread SPREAD."""
    splits: Sequence[str] = list(WEIGHTS)
    cells, strata = iv.split_cells([(s, "") for s in splits for _ in range(episodes[s])],
                                   WEIGHTS)
    separated = 0
    for _ in range(campaigns):
        diffs = []
        for s in splits:
            amp = math.sqrt(SPREAD[s] ** 2 + gap ** 2)
            diffs.append(np.where(rng.random(episodes[s]) < 0.5 + gap / (2 * amp), amp, -amp))
        d = np.concatenate(diffs)
        base = rng.uniform(30, 70, len(d))
        x = np.stack([base + d / 2, base - d / 2])
        c = iv.compare(["a", "b"], x, np.ones_like(x, dtype=bool), cells,
                       iv.resample_counts(strata, 1000, rng))
        separated += bool(c.beats[0, 1])
    return separated / campaigns


@pytest.mark.slow
def test_the_planned_size_separates_the_gap_about_as_often_as_promised() -> None:
    need = episodes_needed(WEIGHTS, SPREAD, {"standard": 0.5, "challenge": 0.5}, 15.0,
                           pairs=1, power=0.8)
    assert need["standard"] == need["challenge"] > 10
    rng = np.random.default_rng(5)
    planned = _separation(need, 15.0, 300, rng)
    assert 0.72 <= planned <= 0.92, f"planned size separates {planned:.0%} (promised 80 %)"
    quarter = {s: n // 4 for s, n in need.items()}
    assert _separation(quarter, 15.0, 300, rng) < 0.45


def test_more_teams_or_a_finer_gap_need_more_episodes() -> None:
    shares = {"standard": 0.5, "challenge": 0.5}
    base = episodes_needed(WEIGHTS, SPREAD, shares, 10.0, pairs=1)
    assert episodes_needed(WEIGHTS, SPREAD, shares, 10.0, pairs=45)["standard"] > \
        base["standard"]
    assert episodes_needed(WEIGHTS, SPREAD, shares, 5.0, pairs=1)["standard"] > \
        3.5 * base["standard"]  # a quarter of the gap: about four times the episodes


# ------------------------------------------------------------------ the command
@pytest.fixture()
def folder() -> Iterator[Path]:
    path = Path(tempfile.mkdtemp(prefix="eagc-pl-", dir="/tmp"))
    yield path
    shutil.rmtree(path, ignore_errors=True)


def _write(folder: Path, name: str, teams: Sequence[str], n: int, track: str = "track1"
           ) -> Path:
    subs = "\n".join(f"  - {{team: {t}, image: img}}" for t in teams)
    path = folder / f"{name}.yaml"
    path.write_text(f"name: {name}\ntrack: {track}\nphase: local\nsplits:\n"
                    f"  - {{name: standard, episodes: {n}}}\n"
                    f"  - {{name: challenge, episodes: {n}}}\n"
                    f"submissions:\n{subs}\noutput: {folder / 'out'}\n")
    return path


def _result(split: str, total: float, wall_s: float) -> EpisodeResult:
    return EpisodeResult(
        episode="ep" + secrets.token_hex(8), track="track1", split=split, image="img",
        runtime="docker", status=EpisodeStatus.COMPLETED,
        score=ScoreCard(track="track1", total=total, components={}, weights={}),
        stats=EpisodeStats(steps=10, wall_s=wall_s), started_at=0.0, finished_at=wall_s)


def test_a_pilot_gives_the_spread_and_the_durations(folder: Path) -> None:
    pilot = _write(folder, "pilot", ["a", "b", "c"], 12)
    spec = load_campaign(pilot)
    rng = np.random.default_rng(9)
    scores = rng.uniform(0, 1, (3, 24))
    with ResultsStore(store_path(spec)) as store:
        store.register(spec, "c0mm1t", 72)
        for t, team in enumerate("abc"):
            for e in range(24):
                split, index = ("standard", e) if e < 12 else ("challenge", e - 12)
                wall = 120.0 if split == "standard" else 240.0
                store.commit(spec.name, EpisodeKey(team, split, index),
                             _result(split, float(scores[t, e]), wall), retry=0, node=None)
    final = _write(folder, "final", [f"t{i}" for i in range(6)], 10)
    r = CliRunner().invoke(app, ["campaign", "plan", str(final), "--pilot", str(pilot),
                                 "--resolve", "12", "--workers", "3", "--format", "json"])
    assert r.exit_code == 0, r.output
    plan = json.loads(r.stdout)
    want = {}
    for split, cols in (("standard", slice(0, 12)), ("challenge", slice(12, 24))):
        var = [np.var(100 * (scores[a, cols] - scores[b, cols]), ddof=1)
               for a, b in ((0, 1), (0, 2), (1, 2))]
        want[split] = math.sqrt(float(np.mean(var)))
    got = {s["name"]: s for s in plan["splits"]}
    for split in want:
        assert got[split]["spread"] == pytest.approx(want[split])
    assert got["standard"]["episode_s"] == 120.0 and got["challenge"]["episode_s"] == 240.0
    assert plan["pairs"] == 15 and plan["teams"] == 6
    hours = 6 * (got["standard"]["episodes_needed"] * 120
                 + got["challenge"]["episodes_needed"] * 240) / 3600
    assert plan["episode_hours"] == pytest.approx(hours)
    assert plan["wall_hours"] == pytest.approx(hours / 3)
    assert plan["resolves_now"] > 12 >= 0
    text = CliRunner().invoke(app, ["campaign", "plan", str(final), "--pilot", str(pilot),
                                    "--resolve", "12"], env={"COLUMNS": "80"})
    assert text.exit_code == 0 and all(len(line) <= 80 for line in text.stdout.splitlines())
    assert "Needed" in text.stdout and "episode-hours" in text.stdout


def test_every_track_with_baselines_ships_a_reference_spread(folder: Path) -> None:
    for track in ("track1", "track2"):
        path = _write(folder, f"ref-{track}", ["a", "b"], 10, track)
        r = CliRunner().invoke(app, ["campaign", "plan", str(path), "--resolve", "10",
                                     "--format", "json"])
        assert r.exit_code == 0, r.output
        plan = json.loads(r.stdout)
        assert all(15 <= s["spread"] <= 50 for s in plan["splits"]), plan["splits"]
        assert "reference" in plan["spread_source"]
    sanity = _write(folder, "ref-sanity", ["a", "b"], 10, "sanity")
    r = CliRunner().invoke(app, ["campaign", "plan", str(sanity), "--resolve", "10"])
    assert r.exit_code == 2 and "--pilot" in r.output
