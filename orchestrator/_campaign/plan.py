"""Campaign sizing before a campaign is run (``eagc campaign plan``).

How many episodes per split a campaign needs so that two teams ``resolve`` points apart
get separate rank ranges, and what that costs. The leaderboard compares teams paired
(``orchestrator._results.intervals``): the final's difference between two teams has the
variance ``sum_s w_s^2 sd_s^2 / n_s``, where ``w_s`` is the split's weight in eq. 2 and
``sd_s`` the standard deviation of the per-episode score difference of two teams on the
same episode of split ``s`` (the **paired spread**). It comes from a pilot campaign's
teams (every pair on the episodes both played), or, without a pilot, from the track's
``reference_spread`` (measured between neighbouring baselines by its calibration
benchmark).

A gap of ``resolve`` points is separated with probability ``power`` when
``resolve >= (z(1 - a/2) + z(power)) * se``, where ``a`` is ``1 - confidence`` divided by
the number of pairs of the campaign's teams (Bonferroni over every pair: a bound the
leaderboard's max-t step-down never needs more than, so the plan is safe), and ``se`` is
widened as the leaderboard widens its intervals on small
samples. Splits keep the campaign's proportions of episodes.

Cost: episodes x each split's episode duration (the pilot's mean wall time, else the
sum of the stage budgets at the campaign's time scale: an upper bound), as episode-hours,
and as hours of wall time on ``workers`` workers.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass

import numpy as np
from scipy import stats

from orchestrator._errors import UsageError
from orchestrator._results.intervals import widening
from orchestrator._results.leaderboard import split_weights
from plugins import TrackPlugin, load_track
from schemas import CampaignSpec, EpisodeResult

CONFIDENCE = 0.95
POWER = 0.8


@dataclass(frozen=True)
class SplitPlan:
    """One split: its weight, paired spread, episodes now and needed, episode duration."""

    name: str
    weight: float
    spread: float
    episodes_now: int
    episodes_needed: int
    episode_s: float


@dataclass(frozen=True)
class Plan:
    """What a campaign needs to resolve ``resolve`` points, and what it costs."""

    campaign: str
    track: str
    teams: int
    pairs: int
    workers: int
    resolve: float
    confidence: float
    power: float
    spread_source: str
    duration_source: str
    splits: tuple[SplitPlan, ...]
    #: The smallest gap the campaign resolves as it is written (points, at ``power``).
    resolves_now: float

    @property
    def episodes_per_team(self) -> int:
        return sum(s.episodes_needed for s in self.splits)

    @property
    def episode_hours(self) -> float:
        return self.teams * sum(s.episodes_needed * s.episode_s for s in self.splits) / 3600

    @property
    def wall_hours(self) -> float:
        return self.episode_hours / max(1, self.workers)

    def to_json(self) -> str:
        doc = asdict(self)
        doc.update(episodes_per_team=self.episodes_per_team,
                   episodes_total=self.episodes_per_team * self.teams,
                   episode_hours=self.episode_hours, wall_hours=self.wall_hours)
        return json.dumps(doc, indent=2)

    def to_text(self, limit: int = 80) -> str:
        from orchestrator._results.text import TextColumn, table_lines, wrapped

        lines = wrapped(
            f"{self.campaign} · {self.track}: episodes per split to separate two teams "
            f"{self.resolve:g} points apart ({self.power:.0%} of the time, "
            f"{self.confidence:.0%} confidence, Bonferroni over {self.pairs} pair"
            f"{'s' if self.pairs != 1 else ''} of {self.teams} teams)", limit)
        s = self.splits
        lines += ["", *table_lines([
            TextColumn("Split", tuple(x.name for x in s), right=False),
            TextColumn("Weight", tuple(f"{x.weight:.2f}" for x in s)),
            TextColumn("Paired sd", tuple(f"{x.spread:.1f}" for x in s)),
            TextColumn("Now", tuple(str(x.episodes_now) for x in s)),
            TextColumn("Needed", tuple(str(x.episodes_needed) for x in s)),
            TextColumn("Episode min", tuple(f"{x.episode_s / 60:.1f}" for x in s)),
        ]), ""]
        lines += wrapped(
            f"Per team {self.episodes_per_team} episodes; all teams "
            f"{self.episodes_per_team * self.teams}: {self.episode_hours:.1f} episode-hours, "
            f"{self.wall_hours:.1f} h on {self.workers} worker"
            f"{'s' if self.workers != 1 else ''}.", limit)
        lines += wrapped(f"As written, the campaign resolves gaps of {self.resolves_now:.1f} "
                         "points or more.", limit)
        lines += wrapped(f"Paired sd: {self.spread_source}. Episode time: "
                         f"{self.duration_source}.", limit)
        return "\n".join(lines) + "\n"


def _z(confidence: float, pairs: int, power: float) -> float:
    alpha = (1 - confidence) / max(1, pairs)
    return float(stats.norm.isf(alpha / 2) + stats.norm.ppf(power))


def resolvable(weights: Mapping[str, float], spread: Mapping[str, float],
               episodes: Mapping[str, int], *, confidence: float = CONFIDENCE,
               pairs: int = 1, power: float = POWER) -> float:
    """The gap (points) that ``episodes`` per split separate with probability ``power``."""
    total = sum(weights.values())
    var = sum((weights[s] / total) ** 2 * spread[s] ** 2 / episodes[s] for s in weights)
    n = sum(episodes.values())
    return _z(confidence, pairs, power) * math.sqrt(var) * widening(n, len(weights),
                                                                      confidence)


def episodes_needed(weights: Mapping[str, float], spread: Mapping[str, float],
                    shares: Mapping[str, float], resolve: float, *,
                    confidence: float = CONFIDENCE, pairs: int = 1, power: float = POWER
                    ) -> dict[str, int]:
    """Episodes per split (in the proportions ``shares``) that resolve ``resolve`` points."""
    if resolve <= 0:
        raise UsageError(f"--resolve must be above 0 points, not {resolve:g}")

    def split(total: int) -> dict[str, int]:
        return {s: max(2, math.ceil(total * shares[s])) for s in weights}

    def enough(total: int) -> bool:
        return resolvable(weights, spread, split(total), confidence=confidence, pairs=pairs,
                          power=power) <= resolve

    high = 2 * len(weights)
    while not enough(high):  # doubling, then bisection on the total
        high *= 2
        if high > 10_000_000:
            raise UsageError(f"no campaign size resolves {resolve:g} points")
    low = high // 2
    while high - low > 1:
        mid = (low + high) // 2
        low, high = (low, mid) if enough(mid) else (mid, high)
    return split(high)


def pilot_spread(results: Mapping[str, Mapping[tuple[str, int], EpisodeResult]]
                 ) -> dict[str, float]:
    """Per split, the root mean square over pairs of teams of the standard deviation of
    their per-episode score difference (points), on the episodes both played."""
    teams = sorted(results)
    out: dict[str, list[float]] = {}
    for a_i, a in enumerate(teams):
        for b in teams[a_i + 1:]:
            shared = sorted(set(results[a]) & set(results[b]))
            for split in sorted({k[0] for k in shared}):
                d = [100 * (results[a][k].score.total - results[b][k].score.total)
                     for k in shared if k[0] == split]
                if len(d) > 1:
                    out.setdefault(split, []).append(float(np.var(d, ddof=1)))
    return {s: float(np.sqrt(np.mean(v))) for s, v in out.items()}


def plan_campaign(spec: CampaignSpec, *, resolve: float, workers: int = 1,
                  pilot: Mapping[str, Mapping[tuple[str, int], EpisodeResult]] | None = None,
                  pilot_name: str | None = None, confidence: float = CONFIDENCE,
                  power: float = POWER) -> Plan:
    """The sizing of ``spec`` (see the module docstring)."""
    plugin: TrackPlugin = load_track(spec.track)
    weights = split_weights(spec, plugin) if len(spec.splits) > 1 else \
        {spec.splits[0].name: 1.0}
    teams = len(spec.submissions)
    pairs = teams * (teams - 1) // 2
    if pilot:
        spread = pilot_spread(pilot)
        source = (f"pilot {pilot_name or 'campaign'} ({len(pilot)} teams, paired on shared "
                  "episodes)")
        if len(pilot) < 2:
            raise UsageError("the pilot has fewer than two teams with results: it cannot "
                             "measure a paired spread")
    else:
        spread = dict(plugin.reference_spread)
        source = f"{spec.track}'s reference (neighbouring baselines, calibration benchmark)"
    missing = [s for s in weights if s not in spread]
    if missing:
        where = "the pilot has no paired episodes" if pilot else \
            f"{spec.track} ships no reference spread"
        raise UsageError(f"no paired spread for split(s) {', '.join(missing)}: {where} "
                         "there; run a pilot campaign with two or more teams (--pilot)")
    budget_s = sum(s.budget_s for s in plugin.stages()) * spec.limits.time_scale
    durations: dict[str, float] = {}
    if pilot:
        for split in weights:
            walls = [r.stats.wall_s for mine in pilot.values() for k, r in mine.items()
                     if k[0] == split and r.stats.wall_s > 0]
            durations[split] = float(np.mean(walls)) if walls else budget_s
        duration_source = "the pilot's mean wall time per episode"
    else:
        durations = {s: budget_s for s in weights}
        duration_source = ("the stage budgets' sum (an upper bound; a pilot measures the "
                           "real time)")
    now = {s.name: s.episodes for s in spec.splits}
    shares = {s: now[s] / sum(now.values()) for s in weights}
    needed = episodes_needed(weights, spread, shares, resolve, confidence=confidence,
                             pairs=max(1, pairs), power=power)
    total = sum(weights.values())
    splits = tuple(SplitPlan(s, weights[s] / total, spread[s], now[s], needed[s],
                             durations[s]) for s in weights)
    return Plan(spec.name, spec.track, teams, max(1, pairs), workers, resolve, confidence,
                power, source, duration_source, splits,
                resolvable(weights, spread, now, confidence=confidence, pairs=max(1, pairs),
                           power=power))


def results_by_team(spec: CampaignSpec, store: object
                    ) -> dict[str, dict[tuple[str, int], EpisodeResult]]:
    """A campaign's committed results: team -> (split, index) -> result."""
    out: dict[str, dict[tuple[str, int], EpisodeResult]] = {}
    for e in store.results(spec.name):  # type: ignore[attr-defined]
        out.setdefault(e.key.submission, {})[(e.key.split, e.key.index)] = e.result
    return out
