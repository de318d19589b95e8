"""How sure a leaderboard is: bootstrap intervals and rank ranges from paired episodes.

A team's score is a weighted mean of per-episode scores that are bimodal (about 90 when the
task is done, 10-30 when not), so a final over a few dozen episodes is uncertain by several
points. Every team of a campaign plays the same episodes (same split, same index, same
hidden seed), so two teams are compared **paired**, on the episodes both have.

- **Cells.** A statistic is ``sum_c w_c * mean(cell c)``: paper eq. 2 is one cell per split
  with the split's weight; Track 2's average is one cell per (split, family) with weight
  ``w_split / families``; a plain mean (task success %) is one cell of every episode.
  Resampling is stratified by the finest cells (split, and the track's own stratum), so a
  resample keeps each split's size and mix.
- **Interval.** 95 % from ``B`` resamples, percentile, expanded for small samples
  (Hesterberg's expanded percentile: the tail level is chosen so that the normal quantile
  equals ``sqrt(n / (n - k)) * t(n - k)``, with ``n`` episodes in ``k`` cells), which keeps
  coverage near 95 % on 20 + 20 bimodal episodes where the plain percentile undercovers.
- **Who beats whom.** For each pair of teams the paired difference of finals is resampled
  on the episodes both have; its p-value is two-sided, from the resampled spread (expanded
  as the intervals are). The pairs are tested together with Holm's method, so that among
  many teams of equal skill no pair is separated in about 95 % of campaigns (a simulation
  of 20 equal teams on 20 + 20 bimodal episodes: 94 %). With two teams this is the plain
  paired test at 95 %: the difference is about two standard errors from zero.
- **Rank range.** Team ``t`` ranks from ``1 + #teams that beat t`` to ``N - #teams t beats``.

Resampling is seeded (by the campaign's name), so the same store prints the same intervals.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

#: Resamples of a leaderboard's intervals and pairwise comparisons.
RESAMPLES = 2000
LEVEL = 0.95


@dataclass(frozen=True)
class Cell:
    """A part of a statistic: the mean of its episodes, weighted by ``weight``."""

    weight: float
    episodes: np.ndarray  # indices into the campaign's episode list
    split: str = ""


@dataclass(frozen=True)
class Interval:
    """A point estimate and its 95 % interval (same scale as the values)."""

    value: float
    low: float
    high: float

    def text(self, digits: int = 1) -> str:
        return f"{self.low:.{digits}f}-{self.high:.{digits}f}"


@dataclass(frozen=True)
class Comparison:
    """What the paired data say about every pair of teams, and each team's rank range."""

    teams: tuple[str, ...]
    #: ``beats[i, j]``: team i's final is above team j's at the campaign's 95 % (jointly).
    beats: np.ndarray
    #: ``prob[i, j]``: share of resamples in which team i's final is above team j's.
    prob: np.ndarray
    #: ``p_value[i, j]``: the paired two-sided p-value of the difference (before Holm).
    p_value: np.ndarray

    def rank_range(self, team: str) -> tuple[int, int]:
        i = self.teams.index(team)
        return 1 + int(self.beats[:, i].sum()), len(self.teams) - int(self.beats[i].sum())


def campaign_seed(name: str) -> int:
    """A resampling seed fixed by the campaign's name."""
    return int.from_bytes(hashlib.sha256(f"eagc-bootstrap/{name}".encode()).digest()[:8], "big")


def resample_counts(strata: np.ndarray, resamples: int, rng: np.random.Generator) -> np.ndarray:
    """``resamples`` × episodes: how often each episode is drawn, stratum by stratum
    (each stratum keeps its size)."""
    counts = np.zeros((resamples, len(strata)), dtype=np.float64)
    for s in np.unique(strata):
        where = np.flatnonzero(strata == s)
        counts[:, where] = rng.multinomial(len(where), np.full(len(where), 1 / len(where)),
                                           size=resamples)
    return counts


def weighted_mean(values: np.ndarray, present: np.ndarray, counts: np.ndarray,
                  cells: Sequence[Cell]) -> np.ndarray:
    """The statistic ``sum_c w_c mean(cell c)`` for each row of ``counts`` (R × episodes)
    and each team of ``values`` / ``present`` (teams × episodes): R × teams. A cell without
    an episode of a team (in the data or in a resample) drops out and the other cells'
    weights are renormalised; a team without any is NaN."""
    x = np.where(present, values, 0.0)
    m = present.astype(np.float64)
    num = np.zeros((counts.shape[0], values.shape[0]))
    wsum = np.zeros_like(num)
    for cell in cells:
        c = counts[:, cell.episodes]
        total = c @ x[:, cell.episodes].T
        n = c @ m[:, cell.episodes].T
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = total / n
        ok = n > 0
        num += np.where(ok, cell.weight * mean, 0.0)
        wsum += np.where(ok, cell.weight, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(wsum > 0, num / wsum, np.nan)


def expanded_tail(n: int, k: int, level: float = LEVEL) -> float:
    """The two-sided tail level of the expanded percentile interval for ``n`` episodes in
    ``k`` cells (plain ``1 - level`` when there are many)."""
    df = n - k
    if df < 1:
        return 1 - level
    wanted = np.sqrt(n / df) * stats.t.ppf(1 - (1 - level) / 2, df)
    return float(2 * stats.norm.sf(wanted))


def interval(values: np.ndarray, present: np.ndarray, cells: Sequence[Cell],
             counts: np.ndarray, level: float = LEVEL) -> list[Interval | None]:
    """Each team's statistic with its expanded percentile interval (None: no episode)."""
    point = weighted_mean(values, present, np.ones((1, values.shape[1])), cells)[0]
    boot = weighted_mean(values, present, counts, cells)
    out: list[Interval | None] = []
    used = {int(i) for c in cells for i in c.episodes}
    for t in range(values.shape[0]):
        if not np.isfinite(point[t]):
            out.append(None)
            continue
        n = int(present[t, sorted(used)].sum())
        k = sum(1 for c in cells if present[t, c.episodes].any())
        tail = expanded_tail(n, k, level)
        b = boot[:, t][np.isfinite(boot[:, t])]
        lo, hi = np.quantile(b, [tail / 2, 1 - tail / 2]) if len(b) else (point[t], point[t])
        out.append(Interval(float(point[t]), float(min(lo, point[t])),
                            float(max(hi, point[t]))))
    return out


def compare(teams: Sequence[str], values: np.ndarray, present: np.ndarray,
            cells: Sequence[Cell], counts: np.ndarray, level: float = LEVEL) -> Comparison:
    """Every pair of teams compared on the episodes both have; Holm's method over the pairs
    keeps the chance of separating any pair of equal teams at ``1 - level`` or less."""
    n_teams = len(teams)
    pairs = [(i, j) for i in range(n_teams) for j in range(i + 1, n_teams)]
    ones = np.ones((1, values.shape[1]))
    beats = np.zeros((n_teams, n_teams), dtype=bool)
    prob = np.full((n_teams, n_teams), 0.5)
    p_value = np.ones((n_teams, n_teams))
    diff = np.zeros((n_teams, n_teams))
    for i, j in pairs:
        both = present[i] & present[j]
        if not both.any():
            continue
        pair_present = np.stack([both, both])
        v = values[[i, j]]
        point = weighted_mean(v, pair_present, ones, cells)[0]
        d = float(point[0] - point[1])
        boot = weighted_mean(v, pair_present, counts, cells)
        b = boot[:, 0] - boot[:, 1]
        b = b[np.isfinite(b)]
        if not np.isfinite(d) or not len(b):
            continue
        n = int(both[np.concatenate([c.episodes for c in cells])].sum())
        k = sum(1 for c in cells if both[c.episodes].any())
        se = float(b.std()) * widening(n, k, level)
        p = float(2 * stats.norm.sf(abs(d) / se)) if se > 0 else float(d == 0)
        above = float(np.mean(b > 0) + 0.5 * np.mean(b == 0))
        diff[i, j], diff[j, i] = d, -d
        p_value[i, j] = p_value[j, i] = p
        prob[i, j], prob[j, i] = above, 1 - above
    # Holm: the k-th smallest p-value is tested at (1 - level) / (m - k + 1), in order,
    # stopping at the first that fails.
    m = len(pairs)
    for rank, p in enumerate(sorted(pairs, key=lambda ij: p_value[ij])):
        if p_value[p] > (1 - level) / (m - rank):
            break
        i, j = p
        beats[i, j], beats[j, i] = diff[i, j] > 0, diff[i, j] < 0
    return Comparison(tuple(teams), beats, prob, p_value)


def widening(n: int, k: int, level: float) -> float:
    """How much wider than normal the expanded percentile interval is (1 with many)."""
    return float(stats.norm.isf(expanded_tail(n, k, level) / 2) / stats.norm.isf((1 - level) / 2))


def split_cells(episodes: Sequence[tuple[str, str]], split_weights: Mapping[str, float]
                ) -> tuple[list[Cell], np.ndarray]:
    """The cells of paper eq. 2 (each split's mean of its strata's means, weighted by the
    split's weight) and each episode's resampling stratum, for ``episodes`` given as
    (split, stratum) pairs."""
    keys = sorted(set(episodes))
    index = {k: n for n, k in enumerate(keys)}
    strata = np.array([index[e] for e in episodes], dtype=np.int64)
    per_split: dict[str, list[tuple[str, str]]] = {}
    for k in keys:
        per_split.setdefault(k[0], []).append(k)
    total = sum(split_weights.get(s, 1.0) for s in per_split)
    cells = [Cell(split_weights.get(s, 1.0) / total / len(ks),
                  np.flatnonzero(strata == index[k]), s)
             for s, ks in per_split.items() for k in ks]
    return cells, strata
