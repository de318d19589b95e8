"""The submission channel: ``CHALLENGE.yaml``, and what the channel's API sends and receives.

A challenge is a track, its teams and its phases; a phase is a window in time and one
campaign (its splits, limits and its own seed secret) that every submission of the phase
plays, so that submissions compare paired. Times are UTC: an ISO date-time
(``2026-06-01T00:00Z``), a date's end Anywhere on Earth (``2026-06-10 AoE``: 23:59 at UTC-12,
the paper's deadlines), or a time relative to the channel's first start (``start``,
``start+2h``, ``start+30m``), so that an example or a rehearsal opens at once.
"""

from __future__ import annotations

import re
from datetime import UTC, datetime, timedelta
from enum import StrEnum
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from schemas._campaign import Limits, Split
from schemas._result import EpisodeResult

#: A team's name: also a folder of the registry (``teams/<team>/…``), so no path tricks.
TEAM_NAME = r"^[a-z0-9][a-z0-9_-]{0,38}$"
_RELATIVE = re.compile(r"^start(?:\s*\+\s*(\d+(?:\.\d+)?)\s*([smhd]))?$")
_AOE = re.compile(r"^(\d{4}-\d{2}-\d{2})(?:[ T](\d{2}:\d{2}))?\s+AoE$")
_UNITS = {"s": 1, "m": 60, "h": 3600, "d": 86400}


def parse_when(text: str, start: datetime) -> datetime:
    """A ``When`` as an aware UTC datetime, given the channel's first start."""
    text = text.strip()
    if m := _RELATIVE.match(text):
        amount = float(m.group(1) or 0) * _UNITS.get(m.group(2) or "s", 1)
        return start + timedelta(seconds=amount)
    if m := _AOE.match(text):
        local = datetime.fromisoformat(f"{m.group(1)}T{m.group(2) or '23:59'}")
        return local.replace(tzinfo=UTC) + timedelta(hours=12)  # AoE is UTC-12
    when = datetime.fromisoformat(text.replace("Z", "+00:00"))
    if when.tzinfo is None:
        raise ValueError(f"{text!r} has no time zone: write it in UTC ('…Z') or as 'AoE'")
    return when.astimezone(UTC)


def _check_when(text: str) -> str:
    try:
        parse_when(text, datetime(2026, 1, 1, tzinfo=UTC))
    except ValueError as e:
        raise ValueError(f"{text!r} is not a time: an ISO date-time in UTC "
                         f"('2026-06-01T00:00Z'), a date's end Anywhere on Earth "
                         f"('2026-06-10 AoE') or 'start+2h' ({e})") from None
    return text


class _Model(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class Preflight(_Model):
    """The free check every submission passes before it may queue: the image exists, its
    size and platform are allowed, and one public episode meets the container contract."""

    split: str | None = Field(default=None, description="A public split (default: the "
                              "track's `dev`, else its first split).")
    seed: int = Field(default=1, ge=0, description="A public seed.")
    time_scale: float = Field(default=0.1, gt=0, le=1.0)
    max_steps_per_stage: int | None = Field(default=300, ge=1)
    max_image_mb: int = Field(default=4096, ge=1, description="Largest image accepted.")
    platforms: tuple[str, ...] = ("linux/amd64",)
    timeout_s: float = Field(default=900.0, gt=0, description="The whole pre-flight's cap.")
    memory_mb: int = Field(default=2048, ge=64)


class Quota(_Model):
    """What a team may use of a phase. The day is the UTC day; a submission is charged when
    it is accepted and refunded when it fails for the platform's reasons, fails its
    pre-flight, or an organizer cancels it."""

    per_day: int = Field(default=5, ge=0, description="Submissions accepted per UTC day.")
    concurrent: int = Field(default=1, ge=1, description="Submissions waiting or running "
                            "at once.")
    failed_preflights_per_day: int = Field(default=10, ge=1, description="Failed pre-flights "
                                           "a day before submissions are refused until the "
                                           "next day (stops abuse of the free check).")


class ChallengePhase(_Model):
    """One window of the challenge and the campaign its submissions play."""

    name: str = Field(pattern=r"^[a-z0-9][a-z0-9_-]*$")
    kind: Literal["testing", "qualification", "hidden_validation", "final"] = "testing"
    opens: str = "start"
    closes: str | None = Field(default=None, description="None: open until closed by hand.")
    splits: tuple[Split, ...] = Field(min_length=1)
    limits: Limits = Limits()
    retries: int = Field(default=2, ge=0)
    secret: str | None = Field(
        default=None, description="'env:NAME' or 'file:/path'; None: the channel makes one "
        "for the phase in its data folder (private) the first time it starts.")
    preflight: Preflight = Preflight()
    quota: Quota = Quota()
    public_splits: tuple[str, ...] = Field(default=(), description="Splits whose episodes "
                                           "their teams see whole (per-episode scores, the "
                                           "viewer): their seeds are then no secret. The "
                                           "others show a score, an interval and verdicts.")
    who: Literal["all", "finalists"] = Field(
        default="all", description="Who may submit: every team, or the phase's finalists "
        "(`eagc challenge finalists PHASE TEAM…`).")
    board: Literal["public", "team", "organizers"] = Field(
        default="team", description="Who sees the phase's board while it runs: anyone "
        "(public), each team its own row and rank range (team), or organizers only.")
    counts: Literal["latest", "selected", "best"] = Field(
        default="latest", description="Which scored submission of a team the board counts: "
        "its latest, the one it selected before the deadline (its latest if none), or its "
        "best (public splits only: on hidden seeds the best of several draws is luck).")

    _when = field_validator("opens", "closes")(
        classmethod(lambda cls, v: v if v is None else _check_when(v)))

    @model_validator(mode="after")
    def _best_only_public(self) -> ChallengePhase:
        hidden = [s.name for s in self.splits if s.name not in self.public_splits]
        if self.counts == "best" and hidden:
            raise ValueError(f"counts: 'best' picks the luckiest draw on hidden seeds; "
                             f"splits {hidden} are not public: count 'latest' or 'selected'")
        unknown = sorted(set(self.public_splits) - {s.name for s in self.splits})
        if unknown:
            raise ValueError(f"public_splits names splits the phase does not play: {unknown}")
        return self


class ChallengeSpec(_Model):
    """``CHALLENGE.yaml``."""

    name: str = Field(pattern=r"^[a-z0-9][a-z0-9_-]*$")
    track: str
    teams: tuple[str, ...] = Field(default=(), description="Teams added at the first start "
                                   "(more with `eagc challenge teams add`).")
    phases: tuple[ChallengePhase, ...] = Field(min_length=1)
    baselines: tuple[str, ...] = Field(default=(), description="Teams that submit the "
                                       "organizers' baselines: reference rows on every "
                                       "board, out of the rank ranges and the finalists.")
    token_days: float = Field(default=60.0, gt=0, description="Lifetime of a team's token.")
    storage_mb_per_team: int = Field(default=20_000, ge=1, description="The registry's "
                                     "storage a team's images may take; pushes beyond it "
                                     "are refused.")
    appeal_s: float = Field(default=48 * 3600.0, ge=0, description="How long a team may "
                            "appeal an organizer's ruling on an audit finding of its own; "
                            "the phase's results wait for it.")
    lease_s: float = Field(default=60.0, ge=5.0, description="A running submission's lease: "
                           "a runner that stops renewing it loses the submission to the "
                           "queue after this long.")

    @field_validator("teams")
    @classmethod
    def _team_names(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        for name in v:
            if not re.match(TEAM_NAME, name):
                raise ValueError(f"team {name!r}: lower-case letters, digits, '-' and '_', "
                                 "at most 39, starting with a letter or digit")
        return v

    @model_validator(mode="after")
    def _unique_phases(self) -> ChallengeSpec:
        names = [p.name for p in self.phases]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ValueError(f"duplicate phase names: {dupes}")
        return self

    def campaign_name(self, phase: ChallengePhase) -> str:
        """The campaign every submission of ``phase`` plays."""
        return f"{self.name}-{phase.name}"


# ---------------------------------------------------------------------- the API's messages
class SubmissionState(StrEnum):
    """Where a submission is. ``scored``, ``failed`` and ``cancelled`` are final."""

    RECEIVED = "received"
    PREFLIGHT = "preflight"
    QUEUED = "queued"
    RUNNING = "running"
    SCORED = "scored"
    FAILED = "failed"
    CANCELLED = "cancelled"

    @property
    def final(self) -> bool:
        return self in (SubmissionState.SCORED, SubmissionState.FAILED,
                        SubmissionState.CANCELLED)


class SubmitRequest(_Model):
    """``POST /api/v1/submissions``: an image of the team's repository, by tag or digest."""

    image: str = Field(max_length=300, description="teams/<team>/<name>[:tag|@sha256:…]")
    note: str = Field(default="", max_length=500)
    disclosure: str | None = Field(default=None, max_length=200_000, description="The "
                                   "resource disclosure's text (YAML or JSON).")


class FreezeRequest(_Model):
    """``POST /api/v1/final/freeze``: freeze one of the team's submissions for the final,
    with the report (and, when ``statement``, the open-source statement) it uploaded."""

    submission: str = Field(max_length=64)
    statement: bool = Field(default=False, description="Freeze the uploaded open-source "
                            "statement too.")
    phase: str | None = Field(default=None, max_length=64, description="The final phase "
                              "(default: the challenge's phase of kind 'final').")


class HistoryEntry(_Model):
    at: datetime
    state: SubmissionState
    detail: str = ""


class EpisodeVerdict(_Model):
    """What a team is shown of one hidden episode: no seed, no score, no log."""

    index: int
    status: str
    failure_kind: str | None = None


class SplitSummary(_Model):
    """One split of a scored submission, as its team sees it."""

    split: str
    score: float
    low: float
    high: float
    episodes: int
    public: bool
    verdicts: tuple[EpisodeVerdict, ...] = ()
    scores: tuple[float, ...] | None = Field(default=None, description="Per-episode scores: "
                                             "public splits only.")


class SubmissionView(_Model):
    """A submission as its team (or an organizer) sees it."""

    id: str
    team: str
    phase: str
    state: SubmissionState
    image: str = Field(description="The repository and the manifest digest that runs.")
    image_id: str | None = None
    note: str = ""
    created_at: datetime
    updated_at: datetime
    reason: str = Field(default="", description="Why it failed, or what it waits for.")
    position: int | None = Field(default=None, description="1 = next to run (queued only).")
    eta_s: float | None = Field(default=None, description="Seconds until it should start, "
                                "from measured episode durations (queued only).")
    episodes_done: int = 0
    episodes_planned: int = 0
    final: float | None = None
    final_low: float | None = None
    final_high: float | None = None
    splits: tuple[SplitSummary, ...] = ()
    preflight: str = Field(default="", description="The pre-flight's outcome, one line.")
    charged: bool = Field(default=True, description="Counts against the day's quota.")
    history: tuple[HistoryEntry, ...] = ()


class QuotaView(_Model):
    """``GET /api/v1/quota``: what a team has left of the open phase, and when it resets."""

    team: str
    phase: str
    day: str = Field(description="The UTC day counted (YYYY-MM-DD).")
    per_day: int
    granted: int = Field(description="Extra submissions an organizer granted for the day.")
    used: int = Field(description="Submissions charged today (refunds not counted).")
    left: int
    refunded: int = Field(description="Today's submissions refunded (not the team's fault, "
                          "failed pre-flights, organizer cancels).")
    concurrent: int
    active: int = Field(description="Submissions waiting or running now.")
    failed_preflights: int
    failed_preflights_per_day: int
    resets_at: datetime


class Claim(_Model):
    """``POST /api/v1/runner/claim``: the runner asks for work of one kind."""

    runner: str = Field(max_length=100)
    kind: Literal["preflight", "run"]


class Work(_Model):
    """What a claim returns: one submission to check or run, under a lease."""

    id: str
    team: str
    phase: str
    kind: Literal["preflight", "run"]
    image: str = Field(description="registry/teams/<team>/<name>@sha256:… to pull.")
    digest: str
    image_id: str | None = None
    lease_s: float
    disclosure: str | None = None


class Progress(_Model):
    """``POST /api/v1/runner/{id}/heartbeat``: renews the lease, says how far it is."""

    runner: str
    episodes_done: int = 0
    episodes_planned: int = 0
    image_id: str | None = None


class EpisodeRow(_Model):
    """One episode of a run, as the runner reports it to the channel (organizer side)."""

    split: str
    index: int = Field(ge=0)
    result: EpisodeResult


class Outcome(_Model):
    """``POST /api/v1/runner/{id}/report``: the end of a pre-flight or of a run."""

    runner: str
    kind: Literal["preflight", "run"]
    ok: bool = Field(description="Pre-flight passed / the run produced a score.")
    infrastructure: bool = Field(default=False, description="It failed for the platform's "
                                 "reasons, not the team's: retried at no cost.")
    reason: str = Field(default="", max_length=2000)
    image_id: str | None = None
    wall_s: float | None = None
    results: tuple[EpisodeRow, ...] = Field(default=(), description="Every episode of a "
                                            "run, committed to the channel's store.")
