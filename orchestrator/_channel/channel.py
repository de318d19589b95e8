"""The channel's rules: who may submit what, when, and what each party is shown.

``Channel`` is what the API calls: it owns the database, the registry's keys and address,
the clock and the challenge file, and moves submissions through their states::

    received → preflight → queued → running → scored
        ╰──────────┴──────────┴─────────┴──→ failed | cancelled

A submission is taken by a runner under a lease that heartbeats renew; a lease that runs
out puts the submission back where it was waiting (``received`` or ``queued``), so nothing
stays "running" after its runner is gone. A pre-flight that fails for the team's reason
ends the submission at no cost; a failure of the platform's (the registry, the engine, the
cluster) sends it back to wait, up to the phase's ``retries``.

What a team sees of its submission (``view``): states, position and ETA while queued, and
once scored, per split its score with a 95 % interval and each episode's verdict. Of a
hidden split, never a seed, a scenario, a per-episode score or a log (they would let a team
probe fixed hidden seeds); of a public split, everything.
"""

from __future__ import annotations

import json
import secrets
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

from orchestrator._channel.db import ChannelDB, ChannelError, Clock, Row
from orchestrator._channel.registry import Keys, RegistryProcess, repository_team
from schemas import (
    CampaignSpec,
    ChallengePhase,
    ChallengeSpec,
    EpisodeResult,
    EpisodeRow,
    EpisodeVerdict,
    Outcome,
    Progress,
    QuotaView,
    SplitSummary,
    Submission,
    SubmissionState,
    SubmissionView,
    SubmitRequest,
    Work,
    parse_when,
)

S = SubmissionState
_DIGEST = "sha256:"


@dataclass(frozen=True)
class PhaseWindow:
    phase: ChallengePhase
    opens: datetime
    closes: datetime | None

    def open_at(self, now: datetime) -> bool:
        return self.opens <= now and (self.closes is None or now < self.closes)


class Channel:
    """One challenge's channel over its data folder (``--data``)."""

    def __init__(self, spec: ChallengeSpec, data: Path, *, clock: Clock | None = None,
                 registry: RegistryProcess | None = None) -> None:
        self.spec, self.data = spec, data
        self.clock = clock or Clock()
        data.mkdir(parents=True, exist_ok=True)
        data.chmod(0o700)
        self.db = ChannelDB(data / "channel.sqlite", self.clock)
        self.keys = Keys(data / "keys")
        self.registry = registry
        started = self.db.set_meta("started", f"{self.clock.now():.3f}", keep=True)
        self.started = self.clock.utc(float(started))
        self.runner_token = self._secret_file(data / "runner.token")

    # ------------------------------------------------------------------ set-up
    @staticmethod
    def _secret_file(path: Path) -> str:
        if not path.is_file():
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(secrets.token_hex(32) + "\n")
            path.chmod(0o600)
        return path.read_text().strip()

    def add_spec_teams(self) -> list[str]:
        """Adds the teams the challenge file names; returns those that were new."""
        return [t for t in self.spec.teams if self.db.add_team(t)]

    def windows(self) -> list[PhaseWindow]:
        return [PhaseWindow(p, parse_when(p.opens, self.started),
                            None if p.closes is None else parse_when(p.closes, self.started))
                for p in self.spec.phases]

    def open_phase(self) -> ChallengePhase:
        """The phase open now; ChannelError (403) naming the next window otherwise."""
        now = self.clock.utc()
        windows = self.windows()
        for w in windows:
            if w.open_at(now):
                return w.phase
        later = [w for w in windows if w.opens > now]
        if later:
            w = min(later, key=lambda w: w.opens)
            raise ChannelError(f"no phase is open now ({now:%Y-%m-%d %H:%M} UTC): phase "
                               f"{w.phase.name} opens {w.opens:%Y-%m-%d %H:%M} UTC", 403)
        raise ChannelError(f"no phase is open now ({now:%Y-%m-%d %H:%M} UTC): the last one "
                           "has closed", 403)

    def phase(self, name: str) -> ChallengePhase:
        for p in self.spec.phases:
            if p.name == name:
                return p
        raise ChannelError(f"no phase {name!r}", 404)

    def campaign(self, phase: ChallengePhase, runs: Path,
                 submissions: tuple[Submission, ...] = ()) -> CampaignSpec:
        """The campaign every submission of ``phase`` plays (its seeds: campaign name,
        split and index, from the phase's own secret), with the episodes an organizer
        approved for it from the previous phase's data (``sizing``), else the file's."""
        secret = phase.secret or f"file:{self.phase_secret(phase)}"
        sized = self.sizing(phase)
        splits = tuple(s.model_copy(update={"episodes": sized["episodes"][s.name]})
                       if sized and s.name in sized["episodes"] else s for s in phase.splits)
        return CampaignSpec(
            name=self.spec.campaign_name(phase), track=self.spec.track, phase=phase.kind,
            splits=splits, limits=phase.limits, retries=phase.retries, secret=secret,
            output=runs,
            submissions=submissions or (Submission(team="placeholder", image="none"),))

    def sizing(self, phase: ChallengePhase) -> dict[str, Any] | None:
        """The sizing an organizer approved for ``phase`` (``approve_sizing``), if any."""
        text = self.db.meta(f"sizing:{phase.name}")
        return None if text is None else dict(json.loads(text))

    def approve_sizing(self, phase: ChallengePhase, plan: Any, *, cost_cap_h: float,
                       who: str, why: str) -> None:
        """Sets ``phase``'s episodes to ``plan``'s (``eagc campaign plan`` on the previous
        phase's results), before the phase opens (its seeds are then final) and within the
        organizer's cost cap (wall hours on the plan's workers)."""
        window = next(w for w in self.windows() if w.phase.name == phase.name)
        if window.opens <= self.clock.utc():
            raise ChannelError(f"phase {phase.name} opened {utc_text(window.opens)}: its "
                               "episodes, and so its seeds, are final", 409)
        if plan.wall_hours > cost_cap_h:
            raise ChannelError(f"the plan costs {plan.wall_hours:.1f} h of wall time on "
                               f"{plan.workers} worker(s), over the cap of {cost_cap_h:g} h: "
                               "resolve a larger gap, add workers or raise the cap", 409)
        doc = {"episodes": {s.name: s.episodes_needed for s in plan.splits},
               "resolve": plan.resolve, "wall_hours": plan.wall_hours,
               "source": plan.spread_source}
        with self.db.tx() as db:
            db.execute("INSERT OR REPLACE INTO meta VALUES (?, ?)",
                       (f"sizing:{phase.name}", json.dumps(doc)))
            self.db.record_action(db, who, "sizing", phase.name,
                                  f"{doc['episodes']} to resolve {plan.resolve:g} points, "
                                  f"{plan.wall_hours:.1f} h: {why}")

    def pilot(self, phase: ChallengePhase) -> dict[str, dict[tuple[str, int], Any]]:
        """The counted submissions' results of a (previous) phase, by team: what
        ``eagc campaign plan`` measures paired spreads and episode times on."""
        counted = {r.id: team for team, r in self.counted(phase).items()}
        out: dict[str, dict[tuple[str, int], Any]] = {}
        with self.store() as store:
            for e in store.results(self.spec.campaign_name(phase)):
                team = counted.get(e.key.submission)
                if team is not None:
                    out.setdefault(team, {})[(e.key.split, e.key.index)] = e.result
        return out

    def phase_secret(self, phase: ChallengePhase) -> Path:
        path = self.data / "secrets" / f"{phase.name}.secret"
        path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        self._secret_file(path)
        return path

    # ------------------------------------------------------------------ teams' side
    def registry_address(self) -> str:
        if self.registry is None:
            raise ChannelError("the channel's registry is not running", 503)
        return self.registry.address

    def storage(self, team: str) -> tuple[int, int]:
        """(bytes the team's images take in the registry, the cap)."""
        from orchestrator._channel.storage import team_usage

        used = team_usage(self.data / "registry" / "storage", team)
        return used, self.spec.storage_mb_per_team * 2**20

    def submit(self, team: str, req: SubmitRequest) -> SubmissionView:
        """Accepts ``req`` for ``team`` in the open phase: resolves the image's manifest
        digest (from then on only that digest runs) and queues its pre-flight."""
        phase = self.open_phase()
        repository, reference = split_reference(req.image)
        owner = repository_team(repository)
        if owner is None:
            raise ChannelError(f"{req.image!r} is not an image of the channel's registry: "
                               f"push it as teams/{team}/<name>:<tag> (`eagc submit` does)")
        if owner != team:
            raise ChannelError(f"{repository} is not team {team}'s repository: submit an "
                               f"image of teams/{team}/…", 403)
        if self.registry is None:
            raise ChannelError("the channel's registry is not running", 503)
        # Over quota: refused before the registry is asked (``accept`` checks again, in the
        # transaction that charges it).
        self._may_submit(self.db.db, team, phase)
        digest = self.registry.manifest_digest(repository, reference)
        if digest is None:
            raise ChannelError(f"the registry has no image {repository}"
                               f"{'@' if reference.startswith(_DIGEST) else ':'}{reference}: "
                               "push it first (`eagc submit LOCAL_IMAGE` pushes and submits)",
                               404)
        if reference.startswith(_DIGEST) and digest != reference:
            raise ChannelError(f"the registry resolves {reference} to {digest}", 409)
        return self.accept(team, phase, repository, digest, req)

    def accept(self, team: str, phase: ChallengePhase, repository: str, digest: str,
               req: SubmitRequest) -> SubmissionView:
        """Charges ``team`` one submission of ``phase`` (refusing it over the quota) and
        queues its pre-flight."""
        planned = sum(s.episodes for s in phase.splits)
        sid = self.db.create(team=team, phase=phase.name, repository=repository,
                             digest=digest, note=req.note, disclosure=req.disclosure,
                             planned=planned, check=lambda db: self._may_submit(db, team, phase))
        return self.view(sid, team=team)

    # ------------------------------------------------------------------ quotas
    def _counts(self, db: Any, team: str, phase: str, day: str) -> dict[str, int]:
        def one(sql: str, *args: Any) -> int:
            return int(db.execute(sql, args).fetchone()[0] or 0)

        base = "SELECT COUNT(*) FROM submissions WHERE team=? AND phase=?"
        return {
            "used": one(base + " AND day=? AND charged=1", team, phase, day),
            "refunded": one(base + " AND day=? AND charged=0 AND rerun_of IS NULL",
                            team, phase, day),
            "active": one(base + " AND state IN (?, ?, ?, ?)", team, phase,
                          *(str(s) for s in (S.RECEIVED, S.PREFLIGHT, S.QUEUED, S.RUNNING))),
            "failed_preflights": one(base + " AND day=? AND preflight LIKE 'failed:%'",
                                     team, phase, day),
            "granted": one("SELECT SUM(n) FROM grants WHERE team=? AND phase=? AND day=?",
                           team, phase, day),
        }

    def resets_at(self) -> datetime:
        """The next 00:00 UTC, when the day's quota starts again."""
        now = self.clock.utc()
        return datetime(now.year, now.month, now.day, tzinfo=UTC) + timedelta(days=1)

    def quota(self, team: str) -> QuotaView:
        phase = self.open_phase()
        day = self.db.day()
        c = self._counts(self.db.db, team, phase.name, day)
        q = phase.quota
        return QuotaView(team=team, phase=phase.name, day=day, per_day=q.per_day,
                         granted=c["granted"], used=c["used"],
                         left=max(q.per_day + c["granted"] - c["used"], 0),
                         refunded=c["refunded"], concurrent=q.concurrent, active=c["active"],
                         failed_preflights=c["failed_preflights"],
                         failed_preflights_per_day=q.failed_preflights_per_day,
                         resets_at=self.resets_at())

    def _may_submit(self, db: Any, team: str, phase: ChallengePhase) -> None:
        """ChannelError (429) naming the limit and when it resets, or nothing."""
        paused = self.db.meta("paused")
        if paused:
            raise ChannelError(f"the organizers paused the channel: {paused}", 503)
        if phase.who == "finalists" and team not in self.finalists(phase):
            raise ChannelError(f"phase {phase.name} admits its finalists only, and team "
                               f"{team} is not one of them", 403)
        day = self.db.day()
        c = self._counts(db, team, phase.name, day)
        q = phase.quota
        reset = self.resets_at()
        wait = _duration((reset - self.clock.utc()).total_seconds())
        when = f"{reset:%Y-%m-%d %H:%M} UTC (in {wait})"
        if c["failed_preflights"] >= q.failed_preflights_per_day:
            raise ChannelError(f"quota: {c['failed_preflights']} failed pre-flights today, the "
                               f"phase's cap; submissions are accepted again from {when}. "
                               "`eagc test IMAGE` checks an image locally, for free", 429)
        if c["active"] >= q.concurrent:
            raise ChannelError(f"quota: {c['active']} of your submissions wait or run, the "
                               f"phase allows {q.concurrent} at a time: wait for one to end "
                               "or cancel it (`eagc submissions ID --cancel`)", 429)
        allowed = q.per_day + c["granted"]
        if c["used"] >= allowed:
            raise ChannelError(f"quota: you have used your {allowed} submission"
                               f"{'s' if allowed != 1 else ''} of {day} (UTC); the next is "
                               f"accepted from {when}", 429)

    def row_for(self, sid: str, team: str | None) -> Row:
        """A submission's row; one of another team's is 'not found', as a missing one."""
        row = self.db.get(sid)
        if row is None or (team is not None and row.team != team):
            raise ChannelError(f"no submission {sid!r} of team {team}" if team else
                               f"no submission {sid!r}", 404)
        return row

    def view(self, sid: str, *, team: str | None) -> SubmissionView:
        """What ``team`` (None: an organizer) sees of a submission."""
        row = self.row_for(sid, team)
        position = eta = None
        if row.state == S.QUEUED:
            queue = self.db.queue()
            ahead = [r for r in queue if (r.queued_at or 0, r.id) < (row.queued_at or 0, row.id)]
            position = len(ahead) + 1
            per = self.db.seconds_per_episode()
            if per is not None:
                running = self.db.rows(states=(S.RUNNING,))
                left = sum(max(r.episodes_planned - r.episodes_done, 0) for r in running)
                eta = per * (left + sum(r.episodes_planned for r in ahead))
        result = row.result or {}
        return SubmissionView(
            id=row.id, team=row.team, phase=row.phase, state=row.state,
            image=f"{row.repository}@{row.digest}", image_id=row.image_id, note=row.note,
            created_at=self.clock.utc(row.created_at),
            updated_at=self.clock.utc(row.updated_at), reason=row.reason,
            position=position, eta_s=eta, episodes_done=row.episodes_done,
            episodes_planned=row.episodes_planned, final=result.get("final"),
            final_low=result.get("final_low"), final_high=result.get("final_high"),
            splits=tuple(SplitSummary.model_validate(s) for s in result.get("splits", ())),
            preflight=row.preflight, charged=row.charged,
            history=tuple(self.db.history(row.id)))

    def submissions(self, team: str | None) -> list[SubmissionView]:
        return [self.view(r.id, team=team) for r in self.db.rows(team=team)]

    # ------------------------------------------------------------------ runner's side
    def expire_leases(self) -> list[str]:
        """Puts back every submission whose runner stopped renewing its lease."""
        now = self.clock.now()
        back = []
        with self.db.tx() as db:
            for sid, state, phase, tries in db.execute(
                    "SELECT id, state, phase, infra_retries FROM submissions "
                    "WHERE state IN (?, ?) AND lease_until<?",
                    (str(S.PREFLIGHT), str(S.RUNNING), now)).fetchall():
                # A runner that died is the platform's failure: retried free, as many
                # times as the phase retries, then failed and refunded.
                lost = "its runner stopped answering (lease expired)"
                common = dict(lease_owner=None, lease_until=None, infra_retries=tries + 1,
                              lease_expiries=_plus(db, sid, "lease_expiries"))
                if tries + 1 > self._retries(phase):
                    self.db.move(db, sid, S.FAILED, f"infrastructure: {lost}, "
                                 f"{tries + 1} time{'s' if tries else ''}; not the team's "
                                 "fault, refunded", charged=0, **common)
                else:
                    waiting = S.RECEIVED if state == S.PREFLIGHT else S.QUEUED
                    self.db.move(db, sid, waiting, f"back in line: {lost}", **common)
                back.append(sid)
        return back

    def _retries(self, phase: str) -> int:
        try:
            return self.phase(phase).retries
        except ChannelError:  # a phase no longer in the challenge file
            return 0

    def claim(self, runner: str, kind: str) -> Work | None:
        """The oldest submission waiting for ``kind`` of work, leased to ``runner``."""
        self.expire_leases()
        if self.db.meta("paused"):
            return None
        registry = self.registry_address()  # before anything is leased
        waiting, taken = ((S.RECEIVED, S.PREFLIGHT) if kind == "preflight"
                          else (S.QUEUED, S.RUNNING))
        order = "created_at" if kind == "preflight" else "queued_at"
        with self.db.tx() as db:
            got = db.execute(f"SELECT id FROM submissions WHERE state=? ORDER BY {order}, id "
                             "LIMIT 1", (str(waiting),)).fetchone()
            if got is None:
                return None
            sid = got[0]
            what = "pre-flight" if kind == "preflight" else "run"
            self.db.move(db, sid, taken, f"{what} under way on runner {runner}",
                         lease_owner=runner,
                         lease_until=self.clock.now() + self.spec.lease_s)
        row = self.row_for(sid, None)
        return Work(id=sid, team=row.team, phase=row.phase, kind=kind,  # type: ignore[arg-type]
                    image=f"{registry}/{row.repository}@{row.digest}",
                    digest=row.digest, image_id=row.image_id,
                    lease_s=self.clock.real_s(self.spec.lease_s),
                    disclosure=row.disclosure)

    def _leased(self, sid: str, runner: str) -> Row:
        row = self.row_for(sid, None)
        if row.lease_owner != runner or row.state not in (S.PREFLIGHT, S.RUNNING):
            raise ChannelError(f"runner {runner} does not hold {sid} (it is {row.state}): its "
                               "lease expired and the submission went back in line", 409)
        return row

    def heartbeat(self, sid: str, p: Progress) -> None:
        self._leased(sid, p.runner)
        with self.db.tx() as db:
            db.execute("UPDATE submissions SET lease_until=?, episodes_done=?, "
                       "episodes_planned=MAX(episodes_planned, ?), "
                       "image_id=COALESCE(?, image_id) WHERE id=?",
                       (self.clock.now() + self.spec.lease_s, p.episodes_done,
                        p.episodes_planned, p.image_id, sid))

    def report(self, sid: str, o: Outcome) -> SubmissionView:
        row = self._leased(sid, o.runner)
        phase = self.phase(row.phase)
        free = dict(lease_owner=None, lease_until=None)
        if o.image_id:
            free["image_id"] = o.image_id
        with self.db.tx() as db:
            if o.infrastructure:
                tries = row.infra_retries + 1
                if tries > phase.retries:
                    self.db.move(db, sid, S.FAILED, f"infrastructure: {o.reason} (after "
                                 f"{phase.retries} retr{'y' if phase.retries == 1 else 'ies'};"
                                 " not the team's fault, refunded)", infra_retries=tries,
                                 charged=0, **free)
                else:
                    back = S.RECEIVED if o.kind == "preflight" else S.QUEUED
                    self.db.move(db, sid, back, "waiting again after an infrastructure "
                                 "failure (not the team's fault, no cost)",
                                 detail=f"infrastructure: {o.reason}", infra_retries=tries,
                                 **free)
            elif o.kind == "preflight":
                if o.ok:
                    self.db.move(db, sid, S.QUEUED, "waiting for a runner",
                                 detail=f"pre-flight passed: {o.reason}",
                                 queued_at=self.clock.now(), preflight=f"passed: {o.reason}",
                                 **free)
                else:
                    self.db.move(db, sid, S.FAILED, f"pre-flight: {o.reason}",
                                 detail=f"pre-flight: {o.reason} (refunded: a pre-flight "
                                 "costs nothing)", preflight=f"failed: {o.reason}", charged=0,
                                 **free)
            else:
                result = self.summarize(row, phase, o.results)
                self.db.move(db, sid, S.SCORED, "scored",
                             detail=f"final {result.get('final')}",
                             result=json.dumps(result), wall_s=o.wall_s,
                             episodes_done=len(o.results), **free)
        return self.view(sid, team=None)

    # ------------------------------------------------------------------ cancel, organizer
    def cancel(self, sid: str, *, team: str | None, who: str = "", why: str = "") -> None:
        """A team cancels its own waiting or running submission (its slot is free at once;
        the day's charge stays); an organizer (``team`` None) cancels any, free."""
        row = self.row_for(sid, team)
        if row.state.final:
            raise ChannelError(f"{sid} is {row.state} already: nothing to cancel", 409)
        with self.db.tx() as db:
            if team is None:
                self.db.record_action(db, who, "cancel", sid, why)
                self.db.move(db, sid, S.CANCELLED, f"cancelled by the organizers ({who}): "
                             f"{why}; refunded", charged=0, lease_owner=None,
                             lease_until=None)
            else:
                self.db.move(db, sid, S.CANCELLED, "cancelled by the team",
                             lease_owner=None, lease_until=None)

    def rerun(self, sid: str, *, who: str, why: str) -> str:
        """An organizer's free rerun: a new submission of the same image, from its
        pre-flight, with the old one's history pointing to it."""
        row = self.row_for(sid, None)
        new = self.db.create(team=row.team, phase=row.phase, repository=row.repository,
                             digest=row.digest, note=f"rerun of {sid}: {why}",
                             disclosure=row.disclosure, planned=row.episodes_planned,
                             charged=False, rerun_of=sid)
        with self.db.tx() as db:
            self.db.record_action(db, who, "rerun", sid, why)
            self.db._history(db, sid, row.state, f"rerun by the organizers ({who}) as {new}: "
                             f"{why}")
            self.db._history(db, new, S.RECEIVED, f"rerun of {sid} by the organizers "
                             f"({who}): {why}; free")
        return new

    def refund_window(self, start: float, end: float, *, who: str, why: str) -> list[str]:
        """Refunds every charged submission that ended (scored or failed) inside
        ``[start, end]``, an incident's window: the teams get their quota back (a rerun is
        ``rerun``, free too)."""
        with self.db.tx() as db:
            rows = db.execute(
                "SELECT id, state FROM submissions WHERE state IN (?, ?) AND charged=1 AND "
                "updated_at BETWEEN ? AND ? ORDER BY updated_at, id",
                (str(S.FAILED), str(S.SCORED), start, end)).fetchall()
            ids = [sid for sid, _ in rows]
            for sid, state in rows:
                db.execute("UPDATE submissions SET charged=0 WHERE id=?", (sid,))
                self.db._history(db, sid, SubmissionState(state),
                                 f"refunded by the organizers ({who}): {why}")
            self.db.record_action(db, who, "refund", f"{len(ids)} submissions", why)
        return ids

    def grant(self, team: str, n: int, *, who: str, why: str) -> None:
        """``n`` more submissions for ``team`` today, in the open phase."""
        if not self.db.has_team(team):
            raise ChannelError(f"no team {team!r}", 404)
        phase = self.open_phase()
        with self.db.tx() as db:
            db.execute("INSERT INTO grants VALUES (?, ?, ?, ?)",
                       (team, phase.name, self.db.day(), n))
            self.db.record_action(db, who, "grant", team, f"{n} more today: {why}")

    def pause(self, paused: bool, *, who: str, why: str) -> None:
        """Pauses (no submission accepted, no work handed out) or resumes the channel."""
        with self.db.tx() as db:
            if paused:
                db.execute("INSERT OR REPLACE INTO meta VALUES ('paused', ?)",
                           (f"{why} ({who}, {self.clock.utc():%Y-%m-%d %H:%M} UTC)",))
            else:
                db.execute("DELETE FROM meta WHERE key='paused'")
            self.db.record_action(db, who, "pause" if paused else "resume", "channel", why)

    def disable(self, team: str, disabled: bool, *, who: str, why: str) -> None:
        if not self.db.has_team(team):
            raise ChannelError(f"no team {team!r}", 404)
        with self.db.tx() as db:
            db.execute("UPDATE teams SET disabled=? WHERE name=?", (int(disabled), team))
            self.db.record_action(db, who, "disable" if disabled else "enable", team, why)

    # ------------------------------------------------------------------ scores
    def store(self) -> Any:
        from orchestrator._results.store import ResultsStore

        return ResultsStore(self.data / "results.sqlite")

    def summarize(self, row: Row, phase: ChallengePhase,
                  results: tuple[EpisodeRow, ...]) -> dict[str, Any]:
        """Commits a run's results to the channel's store and returns what its team is
        shown: per split its score and interval, each episode's verdict (hidden splits: no
        per-episode score)."""
        from orchestrator._campaign.seeds import commitment, load_secret, seed_list
        from orchestrator._results.leaderboard import build_leaderboard
        from orchestrator._results.store import EpisodeKey

        spec = self.campaign(phase, self.data / "runs",
                             (Submission(team=row.id, image=row.repository, digest=None),))
        with self.store() as store:
            store.register(spec, commitment(spec, seed_list(spec, load_secret(spec))),
                           sum(s.episodes for s in spec.splits))
            for e in results:
                store.commit(spec.name, EpisodeKey(row.id, e.split, e.index), e.result,
                             retry=0, node=None)
            board = build_leaderboard(spec, store)
        mine = board.rows[0]
        public = set(phase.public_splits)
        splits = []
        for s in spec.splits:
            eps = sorted((e for e in results if e.split == s.name), key=lambda e: e.index)
            value = mine.values.get(s.name) if len(spec.splits) > 1 else mine.final
            interval = (mine.intervals.get(s.name) if len(spec.splits) > 1
                        else mine.interval)
            shown = s.name in public
            splits.append(SplitSummary(
                split=s.name, score=value or 0.0,
                low=interval.low if interval else (value or 0.0),
                high=interval.high if interval else (value or 0.0),
                episodes=len(eps), public=shown,
                verdicts=tuple(_verdict(e.index, e.result) for e in eps),
                scores=tuple(100.0 * e.result.score.total for e in eps) if shown else None,
            ).model_dump(mode="json"))
        final = mine.final
        return {"final": final,
                "final_low": mine.interval.low if mine.interval else final,
                "final_high": mine.interval.high if mine.interval else final,
                "splits": splits}

    # ------------------------------------------------------------------ the phase's rules
    def finalists(self, phase: ChallengePhase) -> list[str]:
        """The teams a finalists-only phase admits (set by the organizers)."""
        return list(json.loads(self.db.meta(f"finalists:{phase.name}") or "[]"))

    def set_finalists(self, phase: ChallengePhase, teams: list[str], *, who: str,
                      why: str) -> None:
        unknown = [t for t in teams if not self.db.has_team(t)]
        if unknown:
            raise ChannelError(f"no team {', '.join(unknown)}", 404)
        with self.db.tx() as db:
            db.execute("INSERT OR REPLACE INTO meta VALUES (?, ?)",
                       (f"finalists:{phase.name}", json.dumps(sorted(teams))))
            self.db.record_action(db, who, "finalists", phase.name,
                                  f"{', '.join(sorted(teams))}: {why}")

    def select(self, sid: str, team: str) -> None:
        """The team's choice of the submission its board counts (phase ``counts:
        selected``), made while the phase is open."""
        row = self.row_for(sid, team)
        phase = self.phase(row.phase)
        window = next(w for w in self.windows() if w.phase.name == phase.name)
        if not window.open_at(self.clock.utc()):
            raise ChannelError(f"phase {phase.name} is closed: its selection is final", 403)
        if phase.counts != "selected":
            raise ChannelError(f"phase {phase.name} counts each team's {phase.counts} "
                               "submission: there is nothing to select", 409)
        with self.db.tx() as db:
            db.execute("INSERT OR REPLACE INTO meta VALUES (?, ?)",
                       (f"selected:{phase.name}:{team}", sid))
            self.db._history(db, sid, row.state, "selected by the team for the board")

    def counted(self, phase: ChallengePhase) -> dict[str, Row]:
        """Per team, the scored submission the phase's board counts (``counts``): its
        latest; the one it selected (its latest if none or not scored); or its best final
        (public splits only). A submission accepted before the deadline counts though it
        ran after it."""
        scored: dict[str, list[Row]] = {}
        for r in self.db.rows(phase=phase.name, states=(S.SCORED,)):
            scored.setdefault(r.team, []).append(r)
        out = {}
        for team, rows in scored.items():
            latest = max(rows, key=lambda r: (r.updated_at, r.created_at, r.id))
            if phase.counts == "best":
                out[team] = max(rows, key=lambda r: ((r.result or {}).get("final") or 0.0,
                                                     r.updated_at))
            elif phase.counts == "selected":
                chosen = self.db.meta(f"selected:{phase.name}:{team}")
                out[team] = next((r for r in rows if r.id == chosen), latest)
            else:
                out[team] = latest
        return out

    def board(self, phase: ChallengePhase) -> Any:
        """The phase's leaderboard: each team's counted submission (``counted``), with
        intervals and rank ranges from the paired episodes; rows named by team."""
        from orchestrator._results.leaderboard import build_leaderboard

        counted = self.counted(phase)
        if not counted:
            return None
        subs = tuple(Submission(team=r.id, image=r.repository) for r in counted.values())
        spec = self.campaign(phase, self.data / "runs", subs)
        baselines = [r.id for t, r in counted.items() if t in self.spec.baselines]
        with self.store() as store:
            board = build_leaderboard(spec, store, baselines=baselines)
        names = {r.id: r.team for r in counted.values()}
        for row in board.rows:
            row.team = names.get(row.team, row.team)
        for f in board.failures:
            object.__setattr__(f, "team", names.get(f.team, f.team))
        return board

    def seeds(self, phase: ChallengePhase) -> tuple[str, str]:
        """(the phase's seed commitment, the text it commits to)."""
        from orchestrator._campaign.seeds import (
            commitment,
            load_secret,
            revealed_text,
            seed_list,
        )

        spec = self.campaign(phase, self.data / "runs")
        seeds = seed_list(spec, load_secret(spec))
        return commitment(spec, seeds), revealed_text(spec, seeds)

    def check_seeds_apart(self) -> None:
        """ChannelError if a seed of one phase is also a seed of another (each phase draws
        from its own secret: a reused seed would let one phase's episodes leak into the
        next)."""
        seen: dict[int, str] = {}
        for phase in self.spec.phases:
            for line in self.seeds(phase)[1].splitlines():
                seed = int(line.rsplit(" ", 1)[1])
                if seed in seen and seen[seed] != phase.name:
                    raise ChannelError(f"phases {seen[seed]} and {phase.name} share a seed: "
                                       "give one of them another secret")
                seen[seed] = phase.name

    def reveal(self, phase: ChallengePhase) -> str:
        """The seeds of a closed phase, as its commitment committed to them."""
        window = next(w for w in self.windows() if w.phase.name == phase.name)
        if window.closes is None or self.clock.utc() < window.closes:
            when = "is open until closed" if window.closes is None else (
                f"closes {utc_text(window.closes)}")
            raise ChannelError(f"phase {phase.name} {when}: its seeds are revealed after",
                               403)
        return self.seeds(phase)[1]


def _verdict(index: int, result: EpisodeResult) -> dict[str, Any]:
    return EpisodeVerdict(index=index, status=result.status.value,
                          failure_kind=result.status.failure_kind).model_dump()


def _duration(seconds: float) -> str:
    h, m = divmod(int(max(seconds, 0)) // 60, 60)
    return f"{h} h {m} min" if h else f"{m} min"


def _plus(db: Any, sid: str, column: str) -> int:
    return int(db.execute(f"SELECT {column} FROM submissions WHERE id=?",
                          (sid,)).fetchone()[0]) + 1


def split_reference(image: str) -> tuple[str, str]:
    """``repo@sha256:…`` / ``repo:tag`` / ``repo`` → (repository, reference)."""
    if "@" in image:
        repo, _, ref = image.partition("@")
        return repo, ref
    last = image.rsplit("/", 1)[-1]
    if ":" in last:
        repo, _, tag = image.rpartition(":")
        return repo, tag
    return image, "latest"


def utc_text(t: datetime) -> str:
    return t.astimezone(UTC).strftime("%Y-%m-%d %H:%M UTC")


def aoe_text(t: datetime) -> str:
    """The time Anywhere on Earth (UTC-12), as the paper's deadlines are written."""
    return (t.astimezone(UTC) - timedelta(hours=12)).strftime("%Y-%m-%d %H:%M AoE")
