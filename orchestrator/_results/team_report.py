"""One team's own report of a campaign: ``eagc leaderboard CAMPAIGN --team NAME``.

Its leaderboard row, then every one of its episodes: verdict, score, stages reached, the
limit hit, what was wrong with its files, and the last lines its own agent printed
(``failure.log_tail``, else the episode's ``host/agent.log``). Nothing of any other team,
no seed, no organizer path, and nothing that tells what the hidden scenario held (no score
components, weights or scorer notes).
"""

from __future__ import annotations

import difflib
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from orchestrator._errors import UsageError
from orchestrator._results.leaderboard import Leaderboard, Row, held_back
from orchestrator._results.score_card import file_lines
from schemas import CampaignSpec, EpisodeResult

#: Lines of the agent's own output shown per failed episode (JSON keeps what is stored).
TAIL_LINES = 10


@dataclass(frozen=True)
class TeamEpisode:
    """One of the team's episodes, as the team may see it."""

    split: str
    index: int
    status: str
    score: float | None
    stages_reached: tuple[str, ...]
    stage_reached: str | None
    limit_hit: str | None = None
    exit_code: int | None = None
    oom_killed: bool = False
    message: str = ""
    file_problems: tuple[str, ...] = ()
    agent_output: str = ""


@dataclass(frozen=True)
class TeamReport:
    campaign: str
    track: str
    phase: str
    team: str
    row: Row
    rows: int
    episodes: list[TeamEpisode] = field(default_factory=list)

    def to_json(self) -> str:
        return json.dumps({
            "campaign": self.campaign, "track": self.track, "phase": self.phase,
            "team": self.team, "rank": self.row.rank, "of": self.rows,
            "state": self.row.state, "episodes": self.row.episodes,
            "planned": self.row.planned, "values": self.row.values,
            "ci_low": None if self.row.interval is None else self.row.interval.low,
            "ci_high": None if self.row.interval is None else self.row.interval.high,
            "rank_range": None if self.row.rank_range is None else list(self.row.rank_range),
            "intervals": {k: [i.low, i.high] for k, i in self.row.intervals.items()},
            "episode_reports": [asdict(e) for e in self.episodes],
        }, indent=2)

    def to_text(self, limit: int | None = None, tail: int = TAIL_LINES) -> str:
        from orchestrator._results.text import TextColumn, table_lines, width, wrapped

        limit = limit or width()
        final = self.row.final
        score = "—" if final is None else f"{final:.1f}"
        if self.row.interval is not None:
            score += f" (95% CI {self.row.interval.text()})"
        state = "" if self.row.state == "final" else f" ({self.row.state})"
        ranks = "" if self.row.rank_range is None else \
            f" (the data allow rank {self.row.ranks})"
        lines = wrapped(f"{self.team} in {self.campaign} ({self.track}, {self.phase}): rank "
                        f"{self.row.rank} of {self.rows}{ranks}, final {score}{state}, "
                        f"{self.row.episodes}/{self.row.planned} episodes", limit)
        eps = self.episodes
        lines += ["", *table_lines([
            TextColumn("Episode", tuple(f"{e.split}/{e.index}" for e in eps), right=False),
            TextColumn("Verdict", tuple(e.status for e in eps), right=False),
            TextColumn("Score", tuple("—" if e.score is None else f"{e.score:.1f}"
                                      for e in eps)),
            TextColumn("Stage reached", tuple(e.stage_reached or "none" for e in eps),
                       right=False),
            TextColumn("Limit hit", tuple(e.limit_hit or "—" for e in eps), right=False),
        ])]
        for e in eps:
            if e.status == "completed" and not e.file_problems:
                continue
            lines += ["", *wrapped(f"{e.split}/{e.index}: {e.status}"
                                   + (f" · exit code {e.exit_code}" if e.exit_code is not None
                                      else "") + (" · OOM-killed" if e.oom_killed else ""),
                                   limit)]
            if e.message and e.message != "completed" and not (
                    e.status == "agent_bad_files" and e.file_problems):
                lines += wrapped(e.message, limit, "    ")
            for p in e.file_problems:
                lines += wrapped(p, limit, "    file ")
            out = e.agent_output.rstrip().splitlines()[-tail:] if tail else []
            if out:
                lines.append("    last lines the agent printed:")
                lines += [f"      {line}" for line in out]
            elif tail:
                lines.append("    the agent printed nothing")
        return "\n".join(lines) + "\n"


def _agent_output(result: EpisodeResult) -> str:
    if result.failure is not None and result.failure.log_tail.strip():
        return result.failure.log_tail
    if result.episode_dir:
        log = Path(result.episode_dir) / "host" / "agent.log"
        try:
            return log.read_text(errors="replace")[-4000:]
        except OSError:
            return ""
    return ""


def _episode(result: EpisodeResult, index: int) -> TeamEpisode:
    f = result.failure
    stage = f.stage_reached if f is not None else (
        result.stages_reached[-1] if result.stages_reached else None)
    return TeamEpisode(
        split=result.split, index=index, status=result.status.value,
        score=100.0 * result.score.total, stages_reached=tuple(result.stages_reached),
        stage_reached=stage, limit_hit=f.limit_hit if f else None,
        exit_code=f.exit_code if f else None, oom_killed=f.oom_killed if f else False,
        message=f.message if f else "completed",
        file_problems=tuple(f"{c.name}: {line}" for c in result.files
                            for line in file_lines(c.reason) or ([] if c.ok else ["rejected"])),
        agent_output=_agent_output(result))


def team_report(spec: CampaignSpec, store: Any, board: Leaderboard, team: str) -> TeamReport:
    """The report of ``team`` (a submission of ``spec``); UsageError if there is none."""
    teams = [s.team for s in spec.submissions]
    if team not in teams:
        hint = difflib.get_close_matches(team, teams, n=1, cutoff=0.5)
        did = f" Did you mean {hint[0]!r}?" if hint else ""
        raise UsageError(f"campaign {spec.name!r} has no team {team!r}.{did} Its teams: "
                         f"{', '.join(teams)}")
    row = next(r for r in board.rows if r.team == team)
    episodes = [_episode(e.result, e.key.index) for e in store.results(spec.name)
                if e.key.submission == team]
    episodes += [TeamEpisode(split=q.key.split, index=q.key.index, status="quarantined",
                             score=None, stages_reached=(), stage_reached=None,
                             message=held_back(q.retries, spec.retries))
                 for q in store.quarantined(spec.name) if q.key.submission == team]
    order = {s.name: i for i, s in enumerate(spec.splits)}
    episodes.sort(key=lambda e: (order.get(e.split, len(order)), e.index))
    return TeamReport(spec.name, spec.track, spec.phase, team, row, len(board.rows), episodes)
