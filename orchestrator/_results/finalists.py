"""The finalist cut: every team the data allow within the top K.

"The top K" of a leaderboard is a coin flip wherever rank ranges overlap at the cut, so
the cut keeps **every team whose best rank is K or better** (the smallest rank in its
range, ``orchestrator._results.intervals``): no team is cut by noise. When that admits
more than ``cap`` teams (``2 * K`` unless stated), the qualifying teams are taken in the
point-estimate order (the leaderboard's ``#``: the final, then the tie-breaks) up to the
cap, and teams tied with the last one admitted go through with it; the cut says so.

Baselines (reference systems) are shown with their final and interval but take no place
in the cut: the leaderboard must be built with ``baselines=`` so that they are left out
of the pairwise comparison too, and the teams' ranks count teams only.

A team without a final (or without a rank range) is out and says why; teams whose range
crosses the cut (best rank ≤ K < worst rank) are the ones the data could not separate
at it, and are listed.
"""

from __future__ import annotations

import json
import textwrap
from collections.abc import Collection
from dataclasses import dataclass

from orchestrator._results.leaderboard import Leaderboard, Row


@dataclass(frozen=True)
class FinalistLine:
    """One row of the cut: a team (or a baseline), where it stands and why."""

    team: str
    #: ``in``, ``out`` or ``reference`` (a baseline).
    verdict: str
    #: The order among teams by the point estimates (1 = best; ties share it); 0 for a
    #: baseline or a team without a final.
    order: int
    final: float | None
    ci: tuple[float, float] | None
    rank_range: tuple[int, int] | None
    state: str
    why: str


@dataclass(frozen=True)
class Finalists:
    """The cut of a leaderboard at ``k``, with its policy and the reasons."""

    campaign: str
    k: int
    cap: int
    lines: tuple[FinalistLine, ...]
    #: Teams whose rank range crosses the cut (best ≤ k < worst).
    unseparated: tuple[str, ...]
    #: Teams the data allowed within k but the cap left out.
    capped: tuple[str, ...]

    @property
    def finalists(self) -> tuple[str, ...]:
        return tuple(line.team for line in self.lines if line.verdict == "in")

    def policy(self) -> str:
        return (f"finalists: every team whose best rank (95 %, rank ranges among teams) is "
                f"{self.k} or better; if more than {self.cap} qualify, the first {self.cap} "
                f"by the point estimate (final, then tie-breaks), teams tied with the last "
                f"admitted going through too; baselines are reference rows only")

    def to_text(self, limit: int | None = None) -> str:
        """The cut as plain text within ``limit`` columns (default: ``$COLUMNS``, else the
        terminal's width, else 80)."""
        from orchestrator._results.text import width, wrapped

        limit = limit or width()
        out = [*wrapped(f"{self.campaign}: finalists at K = {self.k} (cap {self.cap})", limit),
               *wrapped(self.policy(), limit), ""]
        for verdict, title in (("in", "IN"), ("out", "OUT"), ("reference", "REFERENCE")):
            rows = [line for line in self.lines if line.verdict == verdict]
            if not rows:
                continue
            out.append(f"{title} ({len(rows)})")
            for line in rows:
                final = "—" if line.final is None else f"{line.final:.1f}"
                ci = "" if line.ci is None else f" [{line.ci[0]:.1f}-{line.ci[1]:.1f}]"
                ranks = ("" if line.rank_range is None else
                         f" ranks {_ranks(line.rank_range)}")
                order = f"#{line.order} " if line.order else ""
                out += textwrap.wrap(f"{order}{line.team}: final {final}{ci}{ranks} — "
                                     f"{line.why}", limit, initial_indent="  ",
                                     subsequent_indent="      ", break_long_words=False,
                                     break_on_hyphens=False)
        out.append("")
        if self.unseparated:
            out += wrapped(f"not separated at the cut (their ranges cross {self.k}/"
                           f"{self.k + 1}): " + ", ".join(self.unseparated), limit)
        else:
            out += wrapped(f"the ranges separate every team at the cut ({self.k}/{self.k + 1})",
                           limit)
        if self.capped:
            out += wrapped(f"left out by the cap of {self.cap}: " + ", ".join(self.capped),
                           limit)
        return "\n".join(out) + "\n"

    def to_json(self) -> str:
        return json.dumps({
            "campaign": self.campaign, "k": self.k, "cap": self.cap, "policy": self.policy(),
            "finalists": list(self.finalists), "unseparated": list(self.unseparated),
            "capped": list(self.capped),
            "rows": [{"team": x.team, "verdict": x.verdict, "order": x.order,
                      "final": x.final, "ci": None if x.ci is None else list(x.ci),
                      "rank_range": None if x.rank_range is None else list(x.rank_range),
                      "state": x.state, "why": x.why} for x in self.lines],
        }, indent=2)


def _ranks(r: tuple[int, int]) -> str:
    return str(r[0]) if r[0] == r[1] else f"{r[0]}-{r[1]}"


def finalists(board: Leaderboard, k: int, *, baselines: Collection[str] = (),
              cap: int | None = None) -> Finalists:
    """The cut of ``board`` at ``k`` (see the module's docstring).

    ``board`` must have been built with the same ``baselines`` (``build_leaderboard(...,
    baselines=...)``), so that its rank ranges count teams only; ``cap`` defaults to
    ``2 * k``. Raises ``ValueError`` for a ``k`` or ``cap`` below 1, a baseline that is not
    on the board, or a board whose comparison still holds a baseline."""
    cap = 2 * k if cap is None else cap
    if k < 1 or cap < k:
        raise ValueError(f"k = {k}, cap = {cap}: k must be 1 or more and the cap at least k")
    names = {r.team for r in board.rows}
    unknown = sorted(set(baselines) - names)
    if unknown:
        raise ValueError(f"baseline(s) not on the board of {board.campaign}: "
                         f"{', '.join(unknown)}")
    if board.comparison is not None and set(board.comparison.teams) & set(baselines):
        raise ValueError("the board compares the baselines with the teams: build it with "
                         "build_leaderboard(..., baselines=...)")
    teams = [r for r in board.rows if r.team not in baselines]
    ranked = [r for r in teams if r.final is not None and r.rank_range is not None]
    order = _order(ranked)
    qualify = [r for r in ranked if r.rank_range is not None and r.rank_range[0] <= k]
    admitted = {r.team for r in qualify}
    capped: list[str] = []
    if len(qualify) > cap:
        last = order[qualify[cap - 1].team]
        admitted = {r.team for r in qualify if order[r.team] <= last}
        capped = [r.team for r in qualify if r.team not in admitted]
    lines: list[FinalistLine] = []
    for r in teams:
        rr = r.rank_range
        if r.final is None or rr is None:
            lines.append(_line(r, "out", 0, f"no final ({r.state}, {r.episodes}/{r.planned} "
                                               "episodes): it cannot be placed"))
            continue
        note = "" if r.state == "final" else f"; {r.state}: the cut may change"
        if r.team in admitted:
            why = (f"within {k} for certain (worst rank {rr[1]})" if rr[1] <= k else
                   f"the data allow it within {k} (best rank {rr[0]})")
            lines.append(_line(r, "in", order[r.team], why + note))
        elif r.team in capped:
            lines.append(_line(r, "out", order[r.team],
                               f"the data allow it within {k} (best rank {rr[0]}), but "
                               f"{len(qualify)} qualify and the cap of {cap} admits the "
                               f"first {cap} by the point estimate" + note))
        else:
            lines.append(_line(r, "out", order[r.team],
                               f"best rank {rr[0]} > {k}: at least {rr[0] - 1} teams are "
                               f"above it at 95 %" + note))
    for r in board.rows:
        if r.team in baselines:
            lines.append(_line(r, "reference", 0, "baseline: shown for reference, not "
                                                  "compared and not in the cut"))
    unseparated = tuple(r.team for r in ranked
                        if r.rank_range is not None and r.rank_range[0] <= k < r.rank_range[1])
    return Finalists(board.campaign, k, cap, tuple(lines), unseparated, tuple(capped))


def _order(rows: list[Row]) -> dict[str, int]:
    """The point-estimate order among ``rows`` (already in the board's order): ties (the
    same board rank) share a place."""
    out: dict[str, int] = {}
    for n, r in enumerate(rows):
        same = n > 0 and r.rank == rows[n - 1].rank
        out[r.team] = out[rows[n - 1].team] if same else n + 1
    return out


def _line(r: Row, verdict: str, order: int, why: str) -> FinalistLine:
    ci = None if r.interval is None else (r.interval.low, r.interval.high)
    return FinalistLine(r.team, verdict, order, r.final, ci, r.rank_range, r.state, why)
