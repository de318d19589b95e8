"""Auditing a team of a campaign (``eagc audit``): replays, reruns and file checks.

``audit_team(spec, team, rerun=K)`` takes the team's committed episodes from the results
store and, for each, runs ``audit_episode`` (``replay --verify``, log steps against the
host's count, the track's file checks: ``orchestrator._episode.audit``); then it runs K of
them again, with the image the campaign ran (the pinned ID) and the same seed, split
parameters, index and limits, on the campaign's runtime, and sets each new score beside
the official one. The report (``TeamAudit``) is organizer-only: it names episode ids and
what the hidden scenario held. ``write_report`` puts it, as text and JSON, in
``<output>/<campaign>/audit/<team>.txt|.json``, and the reruns' episode folders in
``<output>/<campaign>/audit/<team>/reruns/``. The report shows the team's resource
disclosure as the campaign keeps it (``orchestrator._campaign.disclosure``); a missing one
is shown as missing and does not make the team unclean.

A team is *clean* when every replay matches its log and no check raised a flag; warnings
and notes are worth reading but do not make it unclean. docs/audit.md says what each
check means and its limits.
"""

from __future__ import annotations

import shutil
import tempfile
import textwrap
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, computed_field

from orchestrator._campaign.disclosure import KeptDisclosure, kept_disclosures, summary_lines
from orchestrator._campaign.spec import campaign_dir, store_path
from orchestrator._episode.audit import EpisodeAudit, EpisodeAuditError, audit_episode
from orchestrator._errors import UsageError
from orchestrator._results.text import TextColumn, table_lines, wrapped
from schemas import CampaignSpec, EpisodeResult

#: Scores are shown in points, as on the leaderboard.
POINTS = 100.0


class AuditedEpisode(BaseModel):
    """One official episode of the team and what its audit found."""

    model_config = ConfigDict(frozen=True)

    split: str
    index: int
    status: str
    score: float
    """The official score, in points."""
    audit: EpisodeAudit | None
    error: str | None = None
    """Why the episode could not be audited (a folder gone, a log cut short)."""


class Rerun(BaseModel):
    """One episode run again with the same image and seed."""

    model_config = ConfigDict(frozen=True)

    split: str
    index: int
    official_episode: str
    rerun_episode: str
    official: float
    rerun: float
    difference: float
    """rerun − official, in points."""
    official_status: str
    rerun_status: str
    folder: str


class TeamAudit(BaseModel):
    """The audit of one team of one campaign (organizer-only)."""

    model_config = ConfigDict(frozen=True)

    campaign: str
    track: str
    team: str
    image: str
    episodes: tuple[AuditedEpisode, ...]
    reruns: tuple[Rerun, ...] = ()
    disclosure: KeptDisclosure | None = None
    """The team's resource disclosure as the campaign keeps it (``status`` says when it is
    missing or invalid: shown, never a flag)."""

    @computed_field  # type: ignore[prop-decorator]
    @property
    def flags(self) -> int:
        return sum(f.severity == "flag" for e in self.episodes if e.audit is not None
                   for f in e.audit.findings)

    @computed_field  # type: ignore[prop-decorator]
    @property
    def replay_failures(self) -> int:
        return sum(e.audit is None or (e.audit.replay is not None and not e.audit.replay.ok)
                   for e in self.episodes)

    @computed_field  # type: ignore[prop-decorator]
    @property
    def clean(self) -> bool:
        """Every replay matches its log and no check raised a flag."""
        return self.flags == 0 and self.replay_failures == 0


def _runtime(spec: CampaignSpec) -> Any:
    if spec.runtime == "local":
        from orchestrator._runtimes.local import LocalProcessRuntime

        return LocalProcessRuntime(quiet=True)
    from orchestrator._runtimes.docker import DockerRuntime

    return DockerRuntime()


def team_episodes(spec: CampaignSpec, team: str) -> list[tuple[str, int, EpisodeResult]]:
    """The team's committed episodes, (split, index, result), in the campaign's order;
    UsageError when the campaign has no such team or no results yet."""
    from orchestrator._results.store import ResultsStore

    teams = [s.team for s in spec.submissions]
    if team not in teams:
        raise UsageError(f"campaign {spec.name!r} has no team {team!r}; its teams: "
                         f"{', '.join(teams)}")
    path = store_path(spec)
    if not path.exists():
        raise UsageError(f"no results yet: {path} does not exist (run the campaign first)")
    with ResultsStore(path) as store:
        stored = [e for e in store.results(spec.name) if e.key.submission == team]
    if not stored:
        raise UsageError(f"team {team!r} has no committed episode in campaign {spec.name!r}")
    order = {s.name: k for k, s in enumerate(spec.splits)}
    stored.sort(key=lambda e: (order.get(e.key.split, len(order)), e.key.index))
    return [(e.key.split, e.key.index, e.result) for e in stored]


def rerun_choice(episodes: Sequence[tuple[str, int, EpisodeResult]], k: int
                 ) -> list[tuple[str, int, EpisodeResult]]:
    """``k`` of the episodes, taken in turn from each split (lowest indices first)."""
    by_split: dict[str, list[tuple[str, int, EpisodeResult]]] = {}
    for e in episodes:
        by_split.setdefault(e[0], []).append(e)
    out: list[tuple[str, int, EpisodeResult]] = []
    while len(out) < min(k, len(episodes)):
        for items in by_split.values():
            if items and len(out) < k:
                out.append(items.pop(0))
    return out


def rerun_episode(spec: CampaignSpec, team: str, split: str, index: int,
                  official: EpisodeResult, into: Path, *, runtime: Any = None) -> Rerun:
    """Runs one episode again (same image, seed, params, index, limits); its folder goes
    under ``into``."""
    from orchestrator._campaign.seeds import load_secret, seed_list
    from orchestrator._episode.worker import EpisodeSpec, run_episode

    seeds = {(s.split, s.index): s.seed for s in seed_list(spec, load_secret(spec))}
    params = next(s.params for s in spec.splits if s.name == split)
    short = Path(tempfile.mkdtemp(prefix="eagc-audit-"))  # unix socket paths are short
    try:
        result = run_episode(EpisodeSpec(
            track=spec.track, image=official.image, seed=seeds[(split, index)], split=split,
            params=params, limits=spec.limits, runs_dir=short, index=index,
            labels={"campaign": spec.name, "submission": team, "retry": "audit"}),
            runtime or _runtime(spec))
        into.mkdir(parents=True, exist_ok=True)
        folder = into / result.episode
        shutil.move(str(short / result.episode), folder)
    finally:
        shutil.rmtree(short, ignore_errors=True)
    a, b = official.score.total * POINTS, result.score.total * POINTS
    return Rerun(split=split, index=index, official_episode=official.episode,
                 rerun_episode=result.episode, official=a, rerun=b, difference=b - a,
                 official_status=official.status.value, rerun_status=result.status.value,
                 folder=str(folder))


def audit_folder(spec: CampaignSpec) -> Path:
    return campaign_dir(spec) / "audit"


def audit_team(spec: CampaignSpec, team: str, *, rerun: int = 0, runtime: Any = None,
               say: Callable[[str], None] = lambda _: None) -> TeamAudit:
    """The audit of one team (module doc); ``say`` hears progress, one line at a time."""
    if rerun < 0:
        raise UsageError(f"--rerun: {rerun} is below 0")
    episodes = team_episodes(spec, team)
    audited: list[AuditedEpisode] = []
    for n, (split, index, result) in enumerate(episodes, start=1):
        say(f"{team}: auditing {split}/{index} ({n}/{len(episodes)})")
        audit: EpisodeAudit | None = None
        error = None
        try:
            audit = audit_episode(Path(result.episode_dir))
        except (EpisodeAuditError, OSError) as e:
            error = str(e).splitlines()[0] if str(e) else type(e).__name__
        audited.append(AuditedEpisode(split=split, index=index, status=result.status.value,
                                      score=result.score.total * POINTS, audit=audit,
                                      error=error))
    reruns: list[Rerun] = []
    chosen = rerun_choice(episodes, rerun)
    for n, (split, index, result) in enumerate(chosen, start=1):
        say(f"{team}: rerunning {split}/{index} ({n}/{len(chosen)})")
        reruns.append(rerun_episode(spec, team, split, index, result,
                                    audit_folder(spec) / team / "reruns", runtime=runtime))
    return TeamAudit(campaign=spec.name, track=spec.track, team=team,
                     image=episodes[0][2].image, episodes=tuple(audited),
                     reruns=tuple(reruns),
                     disclosure=kept_disclosures(spec, campaign_dir(spec)).get(team))


# ---------------------------------------------------------------------------- the report
def report_lines(audit: TeamAudit, limit: int = 80) -> list[str]:
    """The report as text lines of at most ``limit`` characters."""
    out = wrapped(f"Audit of team {audit.team}, campaign {audit.campaign} ({audit.track}): "
                  "ORGANIZERS ONLY", limit)
    out += wrapped(f"image: {audit.image}", limit)
    verdict = ("clean: every replay matches its log and no check raised a flag"
               if audit.clean else
               f"FLAGGED: {audit.flags} flag(s), {audit.replay_failures} episode(s) whose "
               "replay does not match or could not run")
    out += wrapped(f"verdict: {verdict}", limit)
    if audit.disclosure is not None:
        out += ["", "Resource disclosure (paper Table VIII)"]
        for line in summary_lines(audit.disclosure):
            out += _item(line, limit)
    rows = audit.episodes

    def n(e: AuditedEpisode, severity: str) -> str:
        return "-" if e.audit is None else str(sum(f.severity == severity
                                                   for f in e.audit.findings))

    def replay_cell(e: AuditedEpisode) -> str:
        if e.audit is None or e.audit.replay is None:
            return "-" if e.audit is not None else "ERROR"
        return "ok" if e.audit.replay.ok else "MISMATCH"

    out += ["", "Episodes: replay --verify and file checks"]
    out += table_lines([
        TextColumn("Split", tuple(e.split for e in rows), right=False),
        TextColumn("#", tuple(str(e.index) for e in rows)),
        TextColumn("Episode", tuple(e.audit.episode if e.audit else "-" for e in rows),
                   right=False),
        TextColumn("Score", tuple(f"{e.score:.1f}" for e in rows)),
        TextColumn("Steps", tuple(str(e.audit.host_steps) if e.audit else "-" for e in rows)),
        TextColumn("Replay", tuple(replay_cell(e) for e in rows), right=False),
        TextColumn("Flags", tuple(n(e, "flag") for e in rows)),
        TextColumn("Warnings", tuple(n(e, "warning") for e in rows)),
    ])
    if audit.reruns:
        r = audit.reruns
        out += ["", "Reruns: same image, same seed (score differences in points)"]
        out += table_lines([
            TextColumn("Split", tuple(x.split for x in r), right=False),
            TextColumn("#", tuple(str(x.index) for x in r)),
            TextColumn("Official", tuple(f"{x.official:.1f}" for x in r)),
            TextColumn("Rerun", tuple(f"{x.rerun:.1f}" for x in r)),
            TextColumn("Diff", tuple(f"{x.difference:+.1f}" for x in r)),
            TextColumn("Rerun status", tuple(x.rerun_status for x in r), right=False),
        ])
        worst = max(abs(x.difference) for x in r)
        mean = sum(abs(x.difference) for x in r) / len(r)
        out += wrapped(f"largest |diff| {worst:.1f} points, mean |diff| {mean:.1f} points "
                       f"over {len(r)} rerun(s)", limit)
    details = [(e, f) for e in rows if e.audit is not None for f in e.audit.findings]
    errors = [e for e in rows if e.error is not None]
    mismatched = [e for e in rows if e.audit is not None and e.audit.replay is not None
                  and not e.audit.replay.ok]
    if details or errors or mismatched:
        out += ["", "Findings"]
    for e in errors:
        out += _item(f"{e.split}/{e.index}: [error] not audited: {e.error}", limit)
    for e in mismatched:
        assert e.audit is not None and e.audit.replay is not None
        why = e.audit.replay.error or "; ".join(e.audit.replay.mismatches) or (
            f"{e.audit.replay.hashes_checked} of {e.audit.replay.steps} steps hashed")
        out += _item(f"{e.split}/{e.index}: [replay] {why}", limit)
    order = {"flag": 0, "warning": 1, "note": 2}
    for e, f in sorted(details, key=lambda p: order[p[1].severity]):
        out += _item(f"{e.split}/{e.index}: [{f.severity}] {f.check}: {f.message}", limit)
    return out


def _item(text: str, limit: int) -> list[str]:
    """One finding: wrapped at ``limit``, the lines after the first indented."""
    return textwrap.wrap(text, limit, subsequent_indent="    ", break_long_words=False,
                         break_on_hyphens=False)


def write_report(audit: TeamAudit, folder: Path) -> tuple[Path, Path]:
    """Writes ``<team>.txt`` and ``<team>.json`` under ``folder`` (private); their paths."""
    folder.mkdir(parents=True, exist_ok=True)
    folder.chmod(0o700)
    text, data = folder / f"{audit.team}.txt", folder / f"{audit.team}.json"
    text.write_text("\n".join(report_lines(audit)) + "\n")
    data.write_text(audit.model_dump_json(indent=2) + "\n")
    return text, data
