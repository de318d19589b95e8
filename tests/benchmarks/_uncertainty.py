"""What a calibration run can and cannot tell: intervals, paired order, paired spread.

Both calibration benchmarks play every system on the same seeds, so systems are compared
paired, as a campaign's leaderboard compares teams (``orchestrator._results.intervals``):
each system's final with its 95 % interval, and for each pair of neighbours in the paper's
order the share of resamples that put them in that order. The paired spread (standard
deviation of the per-episode difference between neighbours, per split) is what
``eagc campaign plan`` needs to size a campaign (each track's ``reference_spread``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from orchestrator._results import intervals as iv

#: One system's episodes: (split, seed) -> (stratum, score 0-100).
Episodes = Mapping[tuple[str, int], tuple[str, float]]


def uncertainty_lines(systems: Mapping[str, Episodes], order: Sequence[str],
                      weights: Mapping[str, float], names: Mapping[str, str] | None = None
                      ) -> list[str]:
    """Lines for the benchmark's report (within 80 columns)."""
    names = names or {}
    keys = sorted({k for eps in systems.values() for k in eps})
    teams = list(systems)
    if not keys or not teams:
        return []
    strata_of = {k: next(eps[k][0] for eps in systems.values() if k in eps) for k in keys}
    cells, strata = iv.split_cells([(k[0], strata_of[k]) for k in keys], weights)
    values = np.array([[systems[t][k][1] if k in systems[t] else 0.0 for k in keys]
                       for t in teams])
    present = np.array([[k in systems[t] for k in keys] for t in teams])
    counts = iv.resample_counts(strata, iv.RESAMPLES, np.random.default_rng(0))
    finals = iv.interval(values, present, cells, counts)
    out = ["", "95 % intervals (stratified, paired bootstrap; "
           f"{iv.RESAMPLES} resamples):", f"  {'system':22s}{'Final':>7s}{'95% CI':>14s}"]
    for t, f in zip(teams, finals, strict=True):
        if f is not None:
            out.append(f"  {names.get(t, t)[:21]:22s}{f.value:7.1f}{f.text():>14s}")
    present_order = [s for s in order if s in systems]
    pairs = list(zip(present_order, present_order[1:], strict=False))
    if not pairs:
        return out
    comp = iv.compare(teams, values, present, cells, counts)
    splits = sorted({k[0] for k in keys})
    out += ["", "neighbours in the paper's order, paired on shared seeds (sd: of the",
            f"per-episode difference, by split: {' / '.join(splits)}):",
            f"  {'lower < higher':32s}{'diff':>6s}{'P(order)':>10s}{'sd':>16s}"]
    for a, b in pairs:
        i, j = teams.index(a), teams.index(b)
        both = present[i] & present[j]
        diff = values[j] - values[i]
        sds = []
        for split in splits:
            where = both & np.array([k[0] == split for k in keys])
            if where.sum() > 1:
                sds.append(f"{float(np.std(diff[where], ddof=1)):.0f}")
        point = iv.weighted_mean(values[[j, i]], np.stack([both, both]),
                                 np.ones((1, len(keys))), cells)[0]
        out.append(f"  {a + ' < ' + b:32s}{point[0] - point[1]:6.1f}"
                   f"{comp.prob[j, i]:10.2f}{'/'.join(sds):>16s}")
    return out


def paired_spread(systems: Mapping[str, Episodes], order: Sequence[str]) -> dict[str, float]:
    """Per split, the root mean square over neighbour pairs of the standard deviation of
    their per-episode score difference (points)."""
    out: dict[str, list[float]] = {}
    present = [s for s in order if s in systems]
    for a, b in zip(present, present[1:], strict=False):
        shared = sorted(set(systems[a]) & set(systems[b]))
        for split in sorted({k[0] for k in shared}):
            d = [systems[b][k][1] - systems[a][k][1] for k in shared if k[0] == split]
            if len(d) > 1:
                out.setdefault(split, []).append(float(np.var(d, ddof=1)))
    return {s: float(np.sqrt(np.mean(v))) for s, v in out.items()}
