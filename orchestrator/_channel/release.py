"""Audit, rulings and release: the last steps of a phase, in order, none skipped.

1. ``audit_phase`` audits the teams the phase's board allows within the top N (their
   smallest rank ≤ N): every counted episode replayed and checked (``eagc audit``'s
   ``audit_team``), K of them run again; what does not hold becomes a **finding**.
2. An organizer rules on each finding (``accept``, ``rerun``, ``disqualify``) with a
   reason; the team concerned sees its findings and rulings and may appeal a ruling within
   ``appeal_s`` (``ChallengeSpec``), which sends it back to be ruled again (once).
3. ``release`` refuses while a finding waits for a ruling or an appeal window is open;
   then it writes each team's own report first (``teams/<team>.json``), the public board
   last (``board.json``, ``board.md``): intervals, rank ranges, disqualified teams out.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from orchestrator._channel.channel import Channel, utc_text
from orchestrator._channel.db import ChannelError
from schemas import ChallengePhase, Submission

RULINGS = ("accept", "rerun", "disqualify")
#: A rerun's score this far from the official one (points) is a finding.
RERUN_TOLERANCE = 5.0

_DDL = """
CREATE TABLE IF NOT EXISTS findings (
    id INTEGER PRIMARY KEY AUTOINCREMENT, phase TEXT NOT NULL, team TEXT NOT NULL,
    submission TEXT NOT NULL, detail TEXT NOT NULL, at REAL NOT NULL,
    ruling TEXT, reason TEXT, ruled_by TEXT, ruled_at REAL, appeal TEXT, appealed_at REAL,
    rulings INTEGER NOT NULL DEFAULT 0);
"""


def _tables(channel: Channel) -> None:
    with channel.db.tx() as db:
        db.execute(_DDL)


def audited_teams(channel: Channel, phase: ChallengePhase, top: int) -> list[str]:
    """The teams the board allows within the top ``top``: no team that could be there is
    left unaudited by a coin flip."""
    board = channel.board(phase)
    if board is None:
        return []
    return [r.team for r in board.rows
            if r.rank_range is not None and r.rank_range[0] <= top
            or r.rank_range is None and r.rank <= top]


def audit_phase(channel: Channel, phase: ChallengePhase, top: int, *, rerun: int = 0,
                who: str, say: Any = lambda _: None) -> list[dict[str, Any]]:
    """Audits the top teams (module doc); records and returns the findings."""
    from orchestrator._campaign.audit import audit_folder, audit_team, write_report

    _tables(channel)
    counted = channel.counted(phase)
    found: list[dict[str, Any]] = []
    for team in audited_teams(channel, phase, top):
        row = counted[team]
        spec = channel.campaign(phase, channel.data / "runs", (Submission(
            team=row.id, image=f"{row.repository}@{row.digest}", digest=row.image_id),))
        say(f"auditing team {team} ({row.id})")
        audit = audit_team(spec, row.id, rerun=rerun, say=say)
        write_report(audit, audit_folder(spec))
        details = []
        for e in audit.episodes:
            where = f"{e.split}/{e.index}"
            if e.audit is None:
                details.append(f"{where}: could not be audited: {e.error}")
                continue
            if e.audit.replay is not None and not e.audit.replay.ok:
                details.append(f"{where}: the replay does not match the log")
            details += [f"{where}: {f.message}" for f in e.audit.findings
                        if f.severity == "flag"]
        details += [f"{r.split}/{r.index}: run again it scored {r.rerun:.1f}, officially "
                    f"{r.official:.1f}" for r in audit.reruns
                    if abs(r.difference) > RERUN_TOLERANCE]
        add_findings(channel, phase, team, row.id, details, who=who,
                     what=f"{len(audit.episodes)} episodes, {len(audit.reruns)} reruns")
        found += [{"team": team, "detail": d} for d in details]
    return found


def add_findings(channel: Channel, phase: ChallengePhase, team: str, submission: str,
                 details: list[str], *, who: str, what: str = "") -> None:
    """Records an audit's findings of one team (each then waits for a ruling)."""
    _tables(channel)
    with channel.db.tx() as db:
        for d in details:
            db.execute("INSERT INTO findings (phase, team, submission, detail, at) "
                       "VALUES (?, ?, ?, ?, ?)",
                       (phase.name, team, submission, d, channel.clock.now()))
        channel.db.record_action(db, who, "audit", team,
                                 f"{len(details)} finding(s)" + (f", {what}" if what else ""))


def findings(channel: Channel, phase: str, team: str | None = None) -> list[dict[str, Any]]:
    _tables(channel)
    sql = "SELECT * FROM findings WHERE phase=?" + (" AND team=?" if team else "")
    cur = channel.db.db.execute(sql + " ORDER BY id", (phase, team) if team else (phase,))
    names = [c[0] for c in cur.description]
    return [dict(zip(names, r, strict=True)) for r in cur.fetchall()]


def rule(channel: Channel, finding: int, ruling: str, *, who: str, why: str) -> None:
    """An organizer's ruling on a finding, with its reason (recorded)."""
    if ruling not in RULINGS:
        raise ChannelError(f"a ruling is one of {', '.join(RULINGS)}, not {ruling!r}")
    _tables(channel)
    with channel.db.tx() as db:
        got = db.execute("UPDATE findings SET ruling=?, reason=?, ruled_by=?, ruled_at=?, "
                         "rulings=rulings+1 WHERE id=?",
                         (ruling, why, who, channel.clock.now(), finding))
        if got.rowcount == 0:
            raise ChannelError(f"no finding {finding}", 404)
        channel.db.record_action(db, who, "rule", f"finding {finding}", f"{ruling}: {why}")


def appeal(channel: Channel, finding: int, team: str, text: str) -> None:
    """The team concerned appeals a ruling within the appeal window: the finding waits
    for a new ruling (one appeal per finding)."""
    _tables(channel)
    rows = [f for f in findings_of(channel, finding) if f["team"] == team]
    if not rows:
        raise ChannelError(f"no finding {finding} of team {team}", 404)
    f = rows[0]
    if f["ruled_at"] is None:
        raise ChannelError(f"finding {finding} has no ruling yet to appeal", 409)
    if f["appeal"] is not None:
        raise ChannelError(f"finding {finding} was appealed already", 409)
    closes = f["ruled_at"] + channel.spec.appeal_s
    if channel.clock.now() > closes:
        raise ChannelError(f"the appeal window of finding {finding} closed "
                           f"{utc_text(channel.clock.utc(closes))}", 403)
    with channel.db.tx() as db:
        db.execute("UPDATE findings SET appeal=?, appealed_at=?, ruling=NULL WHERE id=?",
                   (text[:2000], channel.clock.now(), finding))


def findings_of(channel: Channel, finding: int) -> list[dict[str, Any]]:
    cur = channel.db.db.execute("SELECT * FROM findings WHERE id=?", (finding,))
    names = [c[0] for c in cur.description]
    return [dict(zip(names, r, strict=True)) for r in cur.fetchall()]


def holds(channel: Channel, phase: str) -> list[str]:
    """What keeps the phase's results from being released, one line each."""
    out = []
    now = channel.clock.now()
    for f in findings(channel, phase):
        if f["ruling"] is None:
            out.append(f"finding {f['id']} (team {f['team']}: {f['detail']}) waits for a "
                       "ruling" + (" after its appeal" if f["appeal"] else ""))
        elif f["appeal"] is None and f["ruled_at"] + channel.spec.appeal_s > now:
            closes = channel.clock.utc(f["ruled_at"] + channel.spec.appeal_s)
            out.append(f"finding {f['id']}: team {f['team']} may appeal until "
                       f"{utc_text(closes)}")
    return out


def release(channel: Channel, phase: ChallengePhase, out: Path, *, who: str,
            why: str) -> list[Path]:
    """Each team's report, then the public board (module doc)."""
    waiting = holds(channel, phase.name)
    if waiting:
        raise ChannelError(f"the results of phase {phase.name} are held: {waiting[0]}"
                           + (f" (and {len(waiting) - 1} more)" if len(waiting) > 1 else ""),
                           409)
    board = channel.board(phase)
    if board is None:
        raise ChannelError(f"phase {phase.name} has no scored submission to release", 409)
    out.mkdir(parents=True, exist_ok=True)
    out_of = {f["team"] for f in findings(channel, phase.name) if f["ruling"] == "disqualify"}
    counted = channel.counted(phase)
    rows = [{"rank": r.rank, "ranks": r.ranks, "team": r.team, "final": r.final,
             "low": r.interval.low if r.interval else None,
             "high": r.interval.high if r.interval else None,
             "episodes": r.episodes, **{k: v for k, v in r.values.items() if k != "final"}}
            for r in board.rows if r.team not in out_of]
    written = []
    for r in board.rows:  # the teams first
        mine = findings(channel, phase.name, r.team)
        path = out / "teams" / f"{r.team}.json"
        path.parent.mkdir(exist_ok=True)
        path.write_text(json.dumps({
            "phase": phase.name, "team": r.team, "disqualified": r.team in out_of,
            "row": next((x for x in rows if x["team"] == r.team), None),
            "audit": [{k: f[k] for k in ("id", "detail", "ruling", "reason", "appeal")}
                      for f in mine]}, indent=1, default=str))
        written.append(path)
    (out / "board.json").write_text(json.dumps({"phase": phase.name, "rows": rows,
                                                "disqualified": sorted(out_of)}, indent=1))
    lines = [f"# {channel.spec.name}: phase {phase.name}", "",
             "| rank | ranks | team | final | 95 % interval | episodes |",
             "|---|---|---|---|---|---|"]
    lines += [f"| {x['rank']} | {x['ranks']} | {x['team']} | "
              f"{'—' if x['final'] is None else format(x['final'], '.1f')} | "
              + (f"{x['low']:.1f}–{x['high']:.1f}" if x["low"] is not None else "—")
              + f" | {x['episodes']} |" for x in rows]
    (out / "board.md").write_text("\n".join(lines) + "\n")
    (out / "index.html").write_text(public_page(channel, phase, board, out_of, counted))
    written += [out / "board.json", out / "board.md", out / "index.html"]
    with channel.db.tx() as db:
        channel.db.record_action(db, who, "release", phase.name, why)
    return written


def _disclosure(team: str, text: str | None) -> list[str]:
    """A team's resource disclosure in a few lines (Table VIII), or why there is none."""
    from orchestrator._campaign.disclosure import (
        KeptDisclosure,
        parse_disclosure,
        summary_lines,
    )
    from schemas import FileProblems

    if not text:
        return summary_lines(KeptDisclosure(team=team, status="missing"))
    try:
        got = parse_disclosure(text.encode(), source=f"{team}'s disclosure", suffix=".yaml")
    except FileProblems as e:
        return summary_lines(KeptDisclosure(team=team, status="invalid",
                                            problems=tuple(e.lines)))
    return summary_lines(KeptDisclosure(team=team, status="ok", disclosure=got))


def public_page(channel: Channel, phase: ChallengePhase, board: Any, out_of: set[str],
                counted: dict[str, Any]) -> str:
    """The released board as a page: the track's columns (Table IV / VII), each final's
    interval and rank range, the baselines as reference rows, each team's disclosure, and
    the key that signed the final's manifest."""
    from orchestrator._channel.pages import _env

    columns = [c for c in board.columns if c.key != "final"]
    rows = [{"rank": r.rank, "ranks": r.ranks, "team": r.team, "final": r.final,
             "ci": r.ci, "baseline": r.team in channel.spec.baselines,
             "cells": [board.cell(r, c) for c in columns],
             "disclosure": _disclosure(r.team, counted[r.team].disclosure
                                       if r.team in counted else None)}
            for r in board.rows if r.team not in out_of]
    key = next((p for p in (channel.data / "final" / "manifest.pub",
                            channel.data / "keys" / "manifest.pub") if p.is_file()), None)
    return str(_env().get_template("release.html").render(
        challenge=channel.spec.name, track=channel.spec.track, phase=phase.name,
        titles=[c.title for c in columns], rows=rows, out_of=sorted(out_of),
        key=key.read_text() if key else None, now=channel.clock.utc()))
