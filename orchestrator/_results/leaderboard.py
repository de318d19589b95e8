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
from dataclasses import asdict, dataclass, field
from typing import Any

from plugins import Column, TrackPlugin, load_track
from schemas import CampaignSpec


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


@dataclass
class Leaderboard:
    campaign: str
    track: str
    phase: str
    columns: list[Column]
    rows: list[Row]
    failures: list[FailureLine] = field(default_factory=list)

    # ------------------------------------------------------------------ output
    def cell(self, row: Row, col: Column) -> str:
        v = row.values.get(col.key)
        text = "—" if v is None else cell_text(v, col.fmt)
        if col.key == "final" and row.state != "final":
            text += f" ({row.state})"
        return text

    def to_json(self) -> str:
        return json.dumps({
            "campaign": self.campaign, "track": self.track, "phase": self.phase,
            "columns": [{"key": c.key, "title": c.title, "lower_is_better": c.lower_is_better}
                        for c in self.columns],
            "rows": [{"rank": r.rank, "team": r.team, "state": r.state,
                      "episodes": r.episodes, "planned": r.planned,
                      "quarantined": r.quarantined, "values": r.values} for r in self.rows],
            "failures": [asdict(f) for f in self.failures],
        }, indent=2)

    def to_csv(self) -> str:
        out = io.StringIO()
        w = csv.writer(out)
        w.writerow(["rank", "team", "state", "episodes", *(c.key for c in self.columns)])
        for r in self.rows:
            w.writerow([r.rank, r.team, r.state, r.episodes,
                        *("" if r.values.get(c.key) is None else f"{r.values[c.key]:.6g}"
                          for c in self.columns)])
        return out.getvalue()

    def to_markdown(self) -> str:
        head = ["#", "Team", *(c.title for c in self.columns), "Episodes"]
        lines = [f"## {self.campaign} ({self.track}, {self.phase})", "",
                 "| " + " | ".join(head) + " |",
                 "|" + "|".join(["---:", "---", *(["---:"] * len(self.columns)), "---:"]) + "|"]
        for r in self.rows:
            cells = [str(r.rank), r.team, *(self.cell(r, c) for c in self.columns),
                     f"{r.episodes}/{r.planned}"]
            lines.append("| " + " | ".join(cells) + " |")
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
        from orchestrator._results.text import TextColumn, layout, width

        limit = limit or width()
        key = [TextColumn("#", tuple(str(r.rank) for r in self.rows)),
               TextColumn("Team", tuple(r.team for r in self.rows), right=False)]
        cols = [TextColumn(c.title, tuple(self.cell(r, c) for r in self.rows))
                for c in self.columns]
        cols.append(TextColumn("Episodes", tuple(f"{r.episodes}/{r.planned}"
                                                 for r in self.rows)))
        first = next(i for i, c in enumerate(self.columns) if c.key == "final")
        lines = layout(f"{self.campaign} · {self.track} · {self.phase} (scores 0-100)", key,
                       cols, first, limit)
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
    if "final" not in keys:
        cols.insert(0, Column("final", "Final"))
    at = next(i for i, c in enumerate(cols) if c.key == "final")
    return cols[:at] + splits + cols[at:]


def _final(spec: CampaignSpec, plugin: TrackPlugin, row: dict[str, float | None]) -> None:
    """Eq. (2) with the campaign's split weights, when every split has a score."""
    if len(spec.splits) < 2 or any(row.get(s.name) is None for s in spec.splits):
        return
    weights = {s.name: s.weight if "weight" in s.model_fields_set
               else plugin.splits.get(s.name, (s.weight, {}))[0] for s in spec.splits}
    total = sum(weights.values())
    row["final"] = sum(w * (row[s] or 0.0) for s, w in weights.items()) / total


def _rank_key(row: Row, keys: list[str], lower: dict[str, bool]) -> tuple[Any, ...]:
    out: list[Any] = []
    for k in keys:
        v = row.values.get(k)
        out.append((v is None, 0.0 if v is None else (v if lower.get(k) else -v)))
    return tuple(out)


def build_leaderboard(spec: CampaignSpec, store: Any) -> Leaderboard:
    """The leaderboard of ``spec`` from what ``store`` (a ResultsStore) holds."""
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
    keys = ["final", *plugin.tie_breaks]
    rows.sort(key=lambda r: (_rank_key(r, keys, lower), r.team))
    for i, r in enumerate(rows):
        same = i > 0 and _rank_key(r, keys, lower) == _rank_key(rows[i - 1], keys, lower)
        r.rank = rows[i - 1].rank if same else i + 1

    failures = [
        FailureLine(e.key.submission, e.key.split, e.key.index, f.kind, f.status.value,
                    f.stage_reached, f.limit_hit, f.exit_code, f.oom_killed, f.message)
        for e in stored if (f := e.result.failure) is not None
    ] + [
        FailureLine(q.key.submission, q.key.split, q.key.index, "infra", "quarantined", None,
                    None, None, False, held_back(q.retries, spec.retries)) for q in held
    ]
    failures.sort(key=lambda f: (f.team, f.split, f.index))
    return Leaderboard(spec.name, spec.track, spec.phase, columns, rows, failures)
