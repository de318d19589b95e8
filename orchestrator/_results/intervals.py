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
  on the episodes both have (the same resamples for every pair, so the pairs' joint
  distribution is kept). All pairs are tested together by a max-|t| step-down (Romano and
  Wolf 2005), as in Mogstad, Romano, Shaikh and Wilhelmy's confidence sets for ranks
  (2024): each pair's difference is studentized by its resampled spread; the critical
  value is the 95 % quantile, over the resamples, of the largest centred studentized
  difference among the pairs not yet shown apart, expanded for small samples at the tail
  it stands for as the intervals are (``expanded_critical``); the pairs beyond it are
  shown apart and leave the set (both directions: the test is two-sided, as Holm's was;
  Mogstad et al.'s one-sided form keeps a separated pair's other direction in the max),
  and the quantile is recomputed over the rest until no more pair is shown apart.
  ``method="holm"`` is Holm's method over the pairs' p-values (``pair_p``: the same
  studentized difference and small-sample expansion, at every tail). Simulated as
  ``tests/orchestrator/test_intervals.py`` does (200 campaigns, the same resamples for
  both; ``docs/rankings.md``): 20 equal teams, some pair separated in 3.5 % (10 + 10) /
  5.5 % (20 + 20) / 6.5 % (80 + 80) of campaigns against Holm's 1 / 3.5 / 4 %; true gaps
  separated, 8 teams: 382 against Holm's 288 on 10 + 10, 3023 against 2938 on 80 + 80.
  With two teams both are the plain paired test at 95 %.
- **Rank range.** Team ``t`` ranks from ``1 + #teams that beat t`` to ``N - #teams t beats``.

Resampling is seeded (by the campaign's name), so the same store prints the same intervals.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import stats

#: Resamples of a leaderboard's intervals and pairwise comparisons.
RESAMPLES = 2000
LEVEL = 0.95
#: How the pairs are tested together: the max-t step-down (the leaderboard's) or Holm.
Method = Literal["max-t", "holm"]


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
    #: ``p_value[i, j]``: the paired two-sided p-value of the difference, alone (before
    #: the correction for testing every pair).
    p_value: np.ndarray
    #: How the pairs were tested together: ``max-t`` (step-down) or ``holm``.
    method: Method = "max-t"

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


@dataclass(frozen=True)
class _Pairs:
    """Every pair ``i < j`` of teams on the episodes both have: the difference of their
    statistics on the data and on each resample."""

    i: np.ndarray  # P
    j: np.ndarray  # P
    diff: np.ndarray  # P: team i's statistic minus team j's (NaN: nothing shared)
    boot: np.ndarray  # R x P: the same on each resample (NaN where undefined)
    #: P: episodes both have, and cells with one (the small-sample expansion's n and k).
    n: np.ndarray
    k: np.ndarray
    #: P: some cell has two shared episodes (else the pair's spread is unknown: one
    #: episode a cell says nothing about how much a difference varies).
    spread: np.ndarray


#: A resampled spread below this (points) is none: the difference is the same on every
#: episode.
_TINY = 1e-9
#: Pairs handled at a time (bounds the R x pairs temporaries of a large campaign).
_CHUNK = 1024


def _pairs(values: np.ndarray, present: np.ndarray, cells: Sequence[Cell],
           counts: np.ndarray) -> _Pairs:
    """A pair's statistic is ``sum_c w_c mean_c(x_i - x_j)`` over the episodes of each
    cell both teams have: the difference of the two teams' statistics on those episodes
    (as ``weighted_mean`` computes them), every pair at once."""
    i, j = np.triu_indices(values.shape[0], k=1)
    ones = np.ones((1, values.shape[1]))
    diff, boot = [np.zeros(0)], [np.zeros((counts.shape[0], 0))]
    for at in range(0, len(i), _CHUNK):
        a, b = i[at: at + _CHUNK], j[at: at + _CHUNK]
        shared = present[a] & present[b]
        d = np.where(shared, values[a] - values[b], 0.0)
        diff.append(_pair_means(d, shared, ones, cells)[0])
        boot.append(_pair_means(d, shared, counts, cells))
    shared = present[i] & present[j]
    n = shared[:, np.concatenate([c.episodes for c in cells])].sum(axis=1)
    k = np.zeros(len(i), dtype=np.int64)
    spread = np.zeros(len(i), dtype=bool)
    for c in cells:
        k += shared[:, c.episodes].any(axis=1)
        spread |= shared[:, c.episodes].sum(axis=1) >= 2
    return _Pairs(i, j, np.concatenate(diff), np.concatenate(boot, axis=1), n, k, spread)


def _pair_means(d: np.ndarray, shared: np.ndarray, counts: np.ndarray,
                cells: Sequence[Cell]) -> np.ndarray:
    """``weighted_mean`` of each pair's per-episode differences ``d`` (pairs × episodes,
    zero where not ``shared``) for each row of ``counts``: R × pairs."""
    m = shared.astype(np.float64)
    num = np.zeros((counts.shape[0], d.shape[0]))
    wsum = np.zeros_like(num)
    for cell in cells:
        c = counts[:, cell.episodes]
        n = c @ m[:, cell.episodes].T
        ok = n > 0
        with np.errstate(invalid="ignore", divide="ignore"):
            num += np.where(ok, cell.weight * (c @ d[:, cell.episodes].T) / n, 0.0)
        wsum += np.where(ok, cell.weight, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(wsum > 0, num / wsum, np.nan)


def compare(teams: Sequence[str], values: np.ndarray, present: np.ndarray,
            cells: Sequence[Cell], counts: np.ndarray, level: float = LEVEL, *,
            method: Method = "max-t") -> Comparison:
    """Every pair of teams compared on the episodes both have, all pairs tested together
    so that the chance of separating any pair of equal teams is ``1 - level`` or less:
    by the max-t step-down on the resamples' joint distribution (default), or by Holm's
    method over the pairs' p-values (``method="holm"``)."""
    n_teams = len(teams)
    pairs = _pairs(values, present, cells, counts)
    beats = np.zeros((n_teams, n_teams), dtype=bool)
    prob = np.full((n_teams, n_teams), 0.5)
    p_value = np.ones((n_teams, n_teams))
    finite = np.isfinite(pairs.boot)
    kept = finite.sum(axis=0)
    ok = np.isfinite(pairs.diff) & (kept > 0) & pairs.spread
    b = np.where(finite, pairs.boot, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = b.sum(axis=0) / kept
        spread = np.sqrt(np.where(finite, (b - mean) ** 2, 0.0).sum(axis=0) / kept)
        above = (np.sum(b > 0, axis=0) + 0.5 * np.sum(finite & (b == 0), axis=0)) / kept
        # The pair's difference in resampled standard errors.
        t = np.where(spread > _TINY, pairs.diff / spread, np.sign(pairs.diff) * np.inf)
    t = np.where(ok, np.nan_to_num(t, nan=0.0), 0.0)
    p = np.where(ok, pair_p(t, pairs.n, pairs.k), 1.0)
    prob[pairs.i[ok], pairs.j[ok]] = above[ok]
    prob[pairs.j[ok], pairs.i[ok]] = 1 - above[ok]
    p_value[pairs.i, pairs.j] = p_value[pairs.j, pairs.i] = p
    if method == "holm":
        shown = _holm(p, ok, level)
    elif method == "max-t":
        with np.errstate(invalid="ignore", divide="ignore"):
            draws = np.where(spread > _TINY, (pairs.boot - pairs.diff) / spread, 0.0)
        shown = _max_t(np.abs(t), np.where(finite, np.abs(draws), -np.inf), pairs.n, pairs.k,
                       ok, level)
    else:
        raise ValueError(f"method {method!r}: 'max-t' or 'holm'")
    up, down = shown & (pairs.diff > 0), shown & (pairs.diff < 0)
    beats[pairs.i[up], pairs.j[up]] = True
    beats[pairs.j[down], pairs.i[down]] = True
    return Comparison(tuple(teams), beats, prob, p_value, method)


def _holm(p: np.ndarray, ok: np.ndarray, level: float) -> np.ndarray:
    """Holm: the k-th smallest of the m p-values is tested at (1 - level) / (m - k + 1),
    in order, stopping at the first that fails. Returns the pairs shown apart."""
    shown = np.zeros(len(p), dtype=bool)
    m = len(p)
    for rank, q in enumerate(np.argsort(p, kind="stable")):
        if not ok[q] or p[q] > (1 - level) / (m - rank):
            break
        shown[q] = True
    return shown


def _max_t(t: np.ndarray, draws: np.ndarray, n: np.ndarray, k: np.ndarray, ok: np.ndarray,
           level: float) -> np.ndarray:
    """The max-|t| step-down over the pairs ``ok``: ``t`` (P) their studentized
    differences, ``draws`` (R × P) the same centred on each resample (``-inf`` where a
    pair has no shared episode). Returns the pairs shown apart."""
    active = ok.copy()
    shown = np.zeros_like(ok)
    while active.any():
        crit = float(np.quantile(draws[:, active].max(axis=1), level, method="higher"))
        new = active & (t > expanded_critical(crit, n, k))
        if not new.any():
            break
        shown |= new
        active &= ~new
    return shown


def pair_p(t: np.ndarray, n: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The two-sided p-value of a pair alone, from its studentized difference ``t`` on
    ``n`` shared episodes in ``k`` cells, expanded at every tail as the critical values
    are (the inverse of ``expanded_critical``: ``|t|`` beyond the expanded normal
    quantile of tail ``a / 2`` exactly when the p-value is below ``a``)."""
    df = np.maximum(n - k, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        small = 2 * stats.t.sf(np.abs(t) / np.sqrt(n / df), df)
    return np.where(n - k >= 1, small, 2 * stats.norm.sf(np.abs(t)))


def expanded_critical(crit: float, n: np.ndarray, k: np.ndarray) -> np.ndarray:
    """A critical value of studentized bootstrap differences, expanded for ``n`` episodes
    in ``k`` cells as the intervals are, at the tail it stands for: the normal quantile
    ``crit`` becomes ``sqrt(n / (n - k)) * t(n - k)`` at the same tail (``crit`` itself
    where ``n - k < 1``). At ``crit = 1.96`` this is ``widening``."""
    df = np.maximum(n - k, 1)
    tail = stats.norm.sf(max(crit, 0.0))
    wide = np.sqrt(n / df) * stats.t.isf(tail, df)
    return np.where(n - k >= 1, wide, crit)


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
