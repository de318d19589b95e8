"""Leaderboards from the results store: per split, final (paper eq. 2), failure reports.

Each submission's row is the track plugin's ``summarize`` of its committed episodes, in the
plugin's ``columns``, ranked by ``final`` and then the plugin's ``tie_breaks`` (each in the
direction its column says is better). The final of a campaign with several splits is the
split-weighted mean of the split scores, with the weights the campaign file sets (the
track's own weights for a split whose weight the file leaves out). A submission with a
quarantined episode has its final marked **pending**; one still missing episodes is
**incomplete**.

Failure reports show what a team may see: split and index, status, stage reached, limit
hit, exit code, OOM, the message. Never a seed, a scenario parameter or an organizer path;
a quarantined episode says only that it is held back for an infrastructure failure, and
how often it was retried (as many times as the campaign's ``retries`` allows).

``team_report`` is one team's own view: its row and every one of its episodes (verdict,
score, stage reached, limit hit, what was wrong with its files, the last lines its agent
printed), and nothing of any other team. It is neutral about the hidden scenario: no score
components, weights or scorer notes (``orchestrator._results.score_card``).

The text form fits ``$COLUMNS`` (80 by default) without cutting a name or a value
(``orchestrator._results.text``); the JSON form keeps ``rows[].team``, ``.episodes``,
``.planned`` and ``.values`` (``final`` on a 0–100 scale).
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Collection
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from orchestrator._results import intervals as iv
from plugins import Column, TrackPlugin, load_track
from schemas import CampaignSpec, EpisodeResult

#: The column of the final (eq. 2): every track's summary holds it.
FINAL = "final"


def held_back(retried: int, allowed: int) -> str:
    """What a team reads about its quarantined episode: retried as the campaign allows."""
    how = (f"retried {retried} time{'s' if retried != 1 else ''}" if retried
           else "not retried")
    return (f"infrastructure failure (not the agent's fault), {how} (the campaign allows "
            f"{allowed}), held back until an organizer decides")


@dataclass(frozen=True)
class FailureLine:
    team: str
    split: str
    index: int
    kind: str
    status: str
    stage_reached: str | None
    limit_hit: str | None
    exit_code: int | None
    oom_killed: bool
    message: str


@dataclass
class Row:
    team: str
    values: dict[str, float | None]
    state: str  # final | pending | incomplete
    episodes: int
    planned: int
    quarantined: int = 0
    rank: int = 0
    #: The final's 95 % interval (``orchestrator._results.intervals``); None without one.
    interval: iv.Interval | None = None
    #: The best and worst rank the paired data allow at 95 %.
    rank_range: tuple[int, int] | None = None
    #: Intervals of the split scores and of the track's ``interval_columns``.
    intervals: dict[str, iv.Interval] = field(default_factory=dict)

    @property
    def final(self) -> float | None:
        """The final (eq. 2) on a 0-100 scale; None until every split has a score."""
        return self.values.get(FINAL)

    @property
    def ranks(self) -> str:
        """``1-3``, ``2`` (one rank only) or ``—``."""
        if self.rank_range is None:
            return "—"
        best, worst = self.rank_range
        return str(best) if best == worst else f"{best}-{worst}"

    @property
    def ci(self) -> str:
        return "—" if self.interval is None else self.interval.text()


@dataclass
class Leaderboard:
    campaign: str
    track: str
    phase: str
    columns: list[Column]
    rows: list[Row]
    failures: list[FailureLine] = field(default_factory=list)
    #: The paired comparison of every pair of teams (None: fewer than two with a final).
    comparison: iv.Comparison | None = None

    # ------------------------------------------------------------------ output
    def interval_keys(self) -> list[str]:
        """The keys that carry an interval besides the final, in column order."""
        have = {k for r in self.rows for k in r.intervals}
        return [c.key for c in self.columns if c.key in have]

    def _with_ci(self) -> list[Column]:
        """The columns with the final's interval right after the final."""
        at = next(i for i, c in enumerate(self.columns) if c.key == FINAL)
        return [*self.columns[: at + 1], Column(CI_KEY, "95% CI"), *self.columns[at + 1:]]

    def cell(self, row: Row, col: Column) -> str:
        if col.key == CI_KEY:
            return row.ci
        v = row.values.get(col.key)
        text = "—" if v is None else cell_text(v, col.fmt)
        if col.key == FINAL and row.state != "final":
            text += f" ({row.state})"
        return text

    def to_json(self) -> str:
        return json.dumps({
            "campaign": self.campaign, "track": self.track, "phase": self.phase,
            "columns": [{"key": c.key, "title": c.title, "lower_is_better": c.lower_is_better}
                        for c in self.columns],
            "rows": [{"rank": r.rank, "team": r.team, "state": r.state,
                      "episodes": r.episodes, "planned": r.planned,
                      "quarantined": r.quarantined, "values": r.values,
                      "ci_low": None if r.interval is None else r.interval.low,
                      "ci_high": None if r.interval is None else r.interval.high,
                      "rank_range": None if r.rank_range is None else list(r.rank_range),
                      "intervals": {k: [i.low, i.high] for k, i in r.intervals.items()}}
                     for r in self.rows],
            "intervals": INTERVALS_NOTE,
            "failures": [asdict(f) for f in self.failures],
        }, indent=2)

    def to_csv(self) -> str:
        out = io.StringIO()
        w = csv.writer(out)
        keys = [k for k in self.interval_keys()]
        w.writerow(["rank", "rank_best", "rank_worst", "team", "state", "episodes",
                    *(c.key for c in self.columns), "ci_low", "ci_high",
                    *(f"{k}_{end}" for k in keys for end in ("low", "high"))])
        for r in self.rows:
            best, worst = r.rank_range or ("", "")
            w.writerow([r.rank, best, worst, r.team, r.state, r.episodes,
                        *("" if r.values.get(c.key) is None else f"{r.values[c.key]:.6g}"
                          for c in self.columns),
                        *_ends(r.interval),
                        *(e for k in keys for e in _ends(r.intervals.get(k)))])
        return out.getvalue()

    def to_markdown(self) -> str:
        cols = self._with_ci()
        head = ["#", "Ranks", "Team", *(c.title for c in cols), "Episodes"]
        lines = [f"## {self.campaign} ({self.track}, phase {self.phase})", "",
                 "| " + " | ".join(head) + " |",
                 "|" + "|".join(["---:", "---:", "---", *(["---:"] * len(cols)), "---:"])
                 + "|"]
        for r in self.rows:
            cells = [str(r.rank), r.ranks, r.team, *(self.cell(r, c) for c in cols),
                     f"{r.episodes}/{r.planned}"]
            lines.append("| " + " | ".join(cells) + " |")
        lines += ["", LEGEND]
        if self.failures:
            lines += ["", "### Failed episodes", "",
                      "| Team | Episode | Status | Stage reached | Limit hit | Exit code | OOM "
                      "| What happened |", "|---|---|---|---|---|---:|---|---|"]
            for f in self.failures:
                msg = f.message.replace("|", "\\|").replace("\n", " ")
                lines.append(
                    f"| {f.team} | {f.split}/{f.index} | {f.status} | {f.stage_reached or '—'}"
                    f" | {f.limit_hit or '—'} | {'—' if f.exit_code is None else f.exit_code}"
                    f" | {'yes' if f.oom_killed else 'no'} | {msg} |")
        return "\n".join(lines) + "\n"

    def to_text(self, limit: int | None = None) -> str:
        """The table and the failed episodes as plain text within ``limit`` columns
        (default: ``$COLUMNS``, else the terminal's width, else 80)."""
        from orchestrator._results.text import TextColumn, layout, width, wrapped

        limit = limit or width()
        key = [TextColumn("#", tuple(str(r.rank) for r in self.rows)),
               TextColumn("Ranks", tuple(r.ranks for r in self.rows)),
               TextColumn("Team", tuple(r.team for r in self.rows), right=False)]
        cols = [TextColumn(c.title, tuple(self.cell(r, c) for r in self.rows))
                for c in self._with_ci()]
        cols.append(TextColumn("Episodes", tuple(f"{r.episodes}/{r.planned}"
                                                 for r in self.rows)))
        first = next(i for i, c in enumerate(self.columns) if c.key == FINAL)
        lines = layout(f"{self.campaign} · {self.track} · phase {self.phase} (scores 0-100)", key,
                       cols, first, limit, lead=2)
        lines += ["", *wrapped(LEGEND, limit)]
        if self.failures:
            lines += ["", "failed episodes (what each team may see)"]
            for f in self.failures:
                lines += failure_lines(f, limit)
        return "\n".join(lines) + "\n"

    def render(self, fmt: str, limit: int | None = None) -> str:
        """``table`` (plain text within ``limit`` columns), ``csv``, ``json`` or ``md``."""
        if fmt == "csv":
            return self.to_csv()
        if fmt == "json":
            return self.to_json() + "\n"
        if fmt == "md":
            return self.to_markdown()
        return self.to_text(limit)


CI_KEY = "final_ci"
LEGEND = ("Order (#): the final, then the paper's tie-breaks. Ranks: the ranks the paired "
          "data allow (95 %, max-t step-down over all pairs). 95% CI: the final's interval "
          "(stratified bootstrap over episodes). Overlapping ranks: that order is not settled.")
INTERVALS_NOTE = ("95 % intervals from 2000 stratified bootstrap resamples of the episodes "
                  "(expanded percentile), seeded by the campaign; rank_range: [1 + teams that "
                  "beat it, N - teams it beats], pairs compared on shared episodes, all "
                  "together by a max-t step-down")


def _ends(i: iv.Interval | None) -> tuple[str, str]:
    return ("", "") if i is None else (f"{i.low:.6g}", f"{i.high:.6g}")


def cell_text(v: float, fmt: str) -> str:
    """``fmt`` of ``v``, except between 0 and 1 (a latency of 0.37 ms under ``{:.0f}``
    would read 0): there two significant digits, ``0.37``."""
    return f"{v:.2g}" if 0 < abs(v) < 1 else fmt.format(v)


def failure_lines(f: FailureLine, limit: int, *, with_team: bool = True) -> list[str]:
    """One failed episode in a few lines: who, which, how it ended, what happened."""
    from orchestrator._results.text import wrapped

    head = f"{f.split}/{f.index}  {f.status}"
    if with_team:
        head = f"{f.team}  {head}"
    facts = [f"stage reached: {f.stage_reached or 'none'}"]
    if f.limit_hit:
        facts.append(f"limit hit: {f.limit_hit}")
    if f.exit_code is not None:
        facts.append(f"exit code {f.exit_code}")
    if f.oom_killed:
        facts.append("OOM-killed")
    return [*wrapped(head, limit), *wrapped(" · ".join(facts), limit, "    "),
            *wrapped(f.message, limit, "    ")]


# ---------------------------------------------------------------------------- building
def _columns(spec: CampaignSpec, plugin: TrackPlugin) -> list[Column]:
    keys = {c.key for c in plugin.columns}
    splits = [Column(s.name, s.name.replace("_", " ").title()) for s in spec.splits
              if s.name not in keys] if len(spec.splits) > 1 else []
    cols = list(plugin.columns)
    if FINAL not in keys:
        cols.insert(0, Column(FINAL, "Final"))
    at = next(i for i, c in enumerate(cols) if c.key == FINAL)
    return cols[:at] + splits + cols[at:]


def split_weights(spec: CampaignSpec, plugin: TrackPlugin) -> dict[str, float]:
    """Each split's weight in eq. (2): the campaign file's, else the track's."""
    return {s.name: s.weight if "weight" in s.model_fields_set
            else plugin.splits.get(s.name, (s.weight, {}))[0] for s in spec.splits}


def _final(spec: CampaignSpec, plugin: TrackPlugin, row: dict[str, float | None]) -> None:
    """Eq. (2) with the campaign's split weights, when every split has a score."""
    if len(spec.splits) < 2 or any(row.get(s.name) is None for s in spec.splits):
        return
    weights = split_weights(spec, plugin)
    total = sum(weights.values())
    row[FINAL] = sum(w * (row[s] or 0.0) for s, w in weights.items()) / total


def _rank_key(row: Row, keys: list[str], lower: dict[str, bool]) -> tuple[Any, ...]:
    out: list[Any] = []
    for k in keys:
        v = row.values.get(k)
        out.append((v is None, 0.0 if v is None else (v if lower.get(k) else -v)))
    return tuple(out)


def build_leaderboard(spec: CampaignSpec, store: Any, *,
                      baselines: Collection[str] = ()) -> Leaderboard:
    """The leaderboard of ``spec`` from what ``store`` (a ResultsStore) holds.

    ``baselines``: reference teams, shown with their interval but left out of the pairwise
    comparison (no rank range; the other teams' ranges count teams only)."""
    plugin = load_track(spec.track)
    stored = store.results(spec.name)
    held = store.quarantined(spec.name)
    planned = sum(s.episodes for s in spec.splits)
    rows: list[Row] = []
    for sub in spec.submissions:
        mine = [e.result for e in stored if e.key.submission == sub.team]
        values = plugin.summarize(mine) if mine else {}
        _final(spec, plugin, values)
        n_held = sum(q.key.submission == sub.team for q in held)
        state = ("pending" if n_held else "incomplete" if len(mine) < planned else "final")
        rows.append(Row(sub.team, dict(values), state, len(mine), planned, n_held))
    columns = _columns(spec, plugin)
    lower = {c.key: c.lower_is_better for c in columns}
    keys = [FINAL, *plugin.tie_breaks]
    rows.sort(key=lambda r: (_rank_key(r, keys, lower), r.team))
    for i, r in enumerate(rows):
        same = i > 0 and _rank_key(r, keys, lower) == _rank_key(rows[i - 1], keys, lower)
        r.rank = rows[i - 1].rank if same else i + 1
    mine = {sub.team: {(e.key.split, e.key.index): e.result for e in stored
                       if e.key.submission == sub.team} for sub in spec.submissions}
    comparison = _uncertainty(spec, plugin, rows, mine, set(baselines))

    failures = [
        FailureLine(e.key.submission, e.key.split, e.key.index, f.kind, f.status.value,
                    f.stage_reached, f.limit_hit, f.exit_code, f.oom_killed, f.message)
        for e in stored if (f := e.result.failure) is not None
    ] + [
        FailureLine(q.key.submission, q.key.split, q.key.index, "infra", "quarantined", None,
                    None, None, False, held_back(q.retries, spec.retries)) for q in held
    ]
    failures.sort(key=lambda f: (f.team, f.split, f.index))
    return Leaderboard(spec.name, spec.track, spec.phase, columns, rows, failures, comparison)


def _uncertainty(spec: CampaignSpec, plugin: TrackPlugin, rows: list[Row],
                 results: dict[str, dict[tuple[str, int], EpisodeResult]],
                 baselines: set[str]) -> iv.Comparison | None:
    """Sets each row's intervals and rank range; returns the pairwise comparison."""
    episodes = sorted({k for mine in results.values() for k in mine})
    if not episodes:
        return None
    first = {k: next(m[k] for m in results.values() if k in m) for k in episodes}
    cells, strata = iv.split_cells([(k[0], plugin.stratum(first[k])) for k in episodes],
                                   split_weights(spec, plugin) if len(spec.splits) > 1
                                   else {spec.splits[0].name: 1.0})
    counts = iv.resample_counts(strata, iv.RESAMPLES,
                                np.random.default_rng(iv.campaign_seed(spec.name)))
    teams = [r.team for r in rows]

    def matrix(value: Any) -> tuple[np.ndarray, np.ndarray]:
        vals = np.zeros((len(teams), len(episodes)))
        have = np.zeros_like(vals, dtype=bool)
        for t, team in enumerate(teams):
            for e, k in enumerate(episodes):
                r = results[team].get(k)
                v = None if r is None else value(r)
                if v is not None:
                    vals[t, e], have[t, e] = v, True
        return vals, have

    totals, present = matrix(lambda r: 100.0 * r.score.total)
    finals = iv.interval(totals, present, cells, counts)
    whole = [iv.Cell(1.0, np.arange(len(episodes)))]
    for key, stat_cells, (vals, have) in [
        *((s.name, [c for c in cells if c.split == s.name], (totals, present))
          for s in spec.splits if len(spec.splits) > 1),
        *((k, whole, matrix(lambda r, k=k: None if k not in r.score.metrics
                            else 100.0 * r.score.metrics[k]))
          for k in plugin.interval_columns),
    ]:
        for row, got in zip(rows, iv.interval(vals, have, stat_cells, counts), strict=True):
            if got is not None and row.values.get(key) is not None:
                row.intervals[key] = got
    with_final = [t for t, (row, f) in enumerate(zip(rows, finals, strict=True))
                  if f is not None and row.final is not None]
    for t in with_final:
        rows[t].interval = finals[t]
    ranked = [t for t in with_final if teams[t] not in baselines]
    if len(ranked) < 2:
        for t in ranked:
            rows[t].rank_range = (1, 1)
        return None
    comparison = iv.compare([teams[t] for t in ranked], totals[ranked], present[ranked], cells,
                            counts)
    for t in ranked:
        rows[t].rank_range = comparison.rank_range(teams[t])
    return comparison
