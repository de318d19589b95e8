"""The team page: what a team sees of its submissions in a browser (``docs/channel.md``,
"The team page"), served by the API's process beside ``/api/v1``.

    GET  /login                              the form: team and token
    POST /login                              checks the token as the API does; sets an
                                             HttpOnly, SameSite=Strict cookie; to /team
    GET  /logout                             clears the cookie
    GET  /team                               the team's page (refreshes itself while one of
                                             its submissions waits or runs)
    GET  /team/episodes/{id}/{split}/{index} an episode of a public split, in the viewer

The page shows what the API shows the team (``Channel.view``, ``Channel.quota``) and, of
the phase's board, only the team's own rank range. Of a hidden split: a score with its
interval and each episode's verdict; never a seed, a per-episode score or a log. Refusals
are the API's one-line reasons. Templates: Jinja2 (``templates/``), autoescaped.
"""

from __future__ import annotations

import base64
import hashlib
import logging
import re
import threading
from collections import Counter
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs

from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from starlette.concurrency import run_in_threadpool

from orchestrator._channel.channel import Channel, utc_text
from orchestrator._channel.db import ChannelError
from schemas import (
    EpisodeResult,
    QuotaView,
    SplitSummary,
    SubmissionState,
    SubmissionView,
    __version__,
)

S = SubmissionState
log = logging.getLogger("eagc.channel")
#: The cookie that holds a team's token (HttpOnly, SameSite=Strict).
COOKIE = "eagc_token"
#: Seconds between two refreshes of a page on which something waits or runs.
REFRESH_S = 10
#: What each state means, for the page's legend.
STATES: dict[str, str] = {
    "received": "waiting for its pre-flight",
    "preflight": "the image is pulled by digest and one public episode played against the "
                 "container contract (free)",
    "queued": "waiting for a runner: position 1 is next; the ETA comes from measured "
              "episode durations",
    "running": "playing the phase's campaign, alone: episodes done of planned",
    "scored": "every episode ran: the final and each split's score, with 95 % intervals",
    "failed": "the pre-flight failed (your image), or the platform failed more often than "
              "the phase retries (not your fault, refunded): the reason says which",
    "cancelled": "cancelled by your team or by the organizers (the reason says who)",
}
#: The team page's only script: while something waits or runs, fetch the page again every
#: REFRESH_S seconds and swap its content in, keeping open <details> open.
SCRIPT = """(() => {
  const every = 1000 * Number(document.body.dataset.refresh);
  async function tick() {
    try {
      const r = await fetch(location.pathname, {cache: "no-store"});
      if (!r.ok || r.redirected) { location.reload(); return; }
      const doc = new DOMParser().parseFromString(await r.text(), "text/html");
      const open = [...document.querySelectorAll("details[open]")].map((d) => d.id);
      document.getElementById("live").replaceWith(doc.getElementById("live"));
      for (const id of open) {
        const d = document.getElementById(id);
        if (d) d.open = true;
      }
      if (doc.body.dataset.live !== "1") { document.body.dataset.live = "0"; return; }
    } catch (e) { /* the channel restarts: try again */ }
    setTimeout(tick, every);
  }
  if (document.body.dataset.live === "1") setTimeout(tick, every);
})();"""
_SCRIPT_HASH = base64.b64encode(hashlib.sha256(SCRIPT.encode()).digest()).decode()
#: The team's pages: nothing from elsewhere, only the page's own script, no framing.
_CSP = ("default-src 'none'; style-src 'unsafe-inline'; img-src data:; "
        f"script-src 'sha256-{_SCRIPT_HASH}'; connect-src 'self'; form-action 'self'; "
        "base-uri 'none'; frame-ancestors 'none'")
#: The viewer's episode pages: self-contained (inline script, data: pictures), no fetch.
_EPISODE_CSP = ("default-src 'none'; style-src 'unsafe-inline'; img-src data:; "
                "script-src 'unsafe-inline'; base-uri 'none'; frame-ancestors 'none'")
_SAFE_ID = re.compile(r"^[A-Za-z0-9._-]{1,100}$")


def _env() -> Any:
    from jinja2 import Environment, PackageLoader, StrictUndefined, select_autoescape

    env = Environment(loader=PackageLoader("orchestrator._channel", "templates"),
                      autoescape=select_autoescape(["html"]), undefined=StrictUndefined,
                      trim_blocks=True, lstrip_blocks=True)
    env.filters["score"] = lambda v: "—" if v is None else f"{v:.1f}"
    env.filters["utc"] = lambda t: "—" if t is None else utc_text(t)
    return env


class Pages:
    """The pages of one channel: its templates, and caches of what does not change."""

    def __init__(self, channel: Channel) -> None:
        self.channel = channel
        self.env = _env()
        #: Seconds between two refreshes while something waits or runs (tests shorten it).
        self.refresh_s = REFRESH_S
        self._lock = threading.Lock()
        self._render = threading.Lock()  # one episode page made at a time
        #: phase → (the scored rows it was computed from, the board)
        self._boards: dict[str, tuple[tuple[tuple[str, float], ...], Any]] = {}
        #: submission → (split, index) → its public episode's result (scored: final)
        self._public: dict[str, dict[tuple[str, int], EpisodeResult]] = {}

    # ------------------------------------------------------------------ responses
    def html(self, template: str, status: int = 200, **context: Any) -> HTMLResponse:
        text = self.env.get_template(template).render(
            challenge=self.channel.spec.name, script=SCRIPT, **context)
        return HTMLResponse(text, status_code=status, headers=_headers(_CSP))

    def login_form(self, *, team: str = "", problem: str = "",
                   status: int = 200) -> HTMLResponse:
        return self.html("login.html", status, team=team, problem=problem)

    def problem(self, text: str, status: int) -> HTMLResponse:
        return self.html("problem.html", status, problem=text)

    # ------------------------------------------------------------------ the team page
    def team_page(self, team: str) -> HTMLResponse:
        ch = self.channel
        now = ch.clock.utc()
        header: dict[str, Any] = {"team": team, "track": ch.spec.track, "now": now}
        quota: QuotaView | None = None
        try:
            phase = ch.open_phase()
        except ChannelError as e:
            header.update(phase=None, closed=str(e))
        else:
            w = next(w for w in ch.windows() if w.phase.name == phase.name)
            header.update(phase=phase.name, kind=phase.kind, opens=w.opens, closes=w.closes,
                          closed="")
            quota = ch.quota(team)
        views = list(reversed(ch.submissions(team)))  # newest first
        on_board = {p.name: row.id for p in ch.spec.phases
                    if (row := ch.counted(p).get(team)) is not None}
        scored = [self._scored(v, on_board.get(v.phase) == v.id, team) for v in views
                  if v.state == S.SCORED]
        live = any(not v.state.final for v in views)
        return self.html("team.html", header=header, quota=quota,
                         submissions=[_row(v, now) for v in views], scored=scored,
                         histories=views, states=STATES, live=live, refresh=self.refresh_s)

    def _scored(self, v: SubmissionView, on_board: bool, team: str) -> dict[str, Any]:
        rank = None
        if on_board and self.channel.phase(v.phase).board != "organizers":
            board = self.board(v.phase)
            mine = next((r for r in board.rows if r.team == team), None) if board else None
            if mine is not None and mine.rank_range is not None:
                rank = {"ranks": mine.ranks, "of": sum(r.rank_range is not None
                                                       for r in board.rows)}
        public = self.public_episodes(v) if any(s.public for s in v.splits) else {}
        return {"v": v, "on_board": on_board, "rank": rank,
                "splits": [_split(v, s, public) for s in v.splits]}

    def board(self, phase_name: str) -> Any:
        """The phase's board, computed again only when a scored submission changed."""
        ch = self.channel
        phase = ch.phase(phase_name)
        scored = tuple((r.id, r.updated_at) for r in ch.db.rows(phase=phase.name,
                                                                   states=(S.SCORED,)))
        with self._lock:
            cached = self._boards.get(phase.name)
        if cached is not None and cached[0] == scored:
            return cached[1]
        board = ch.board(phase)
        with self._lock:
            self._boards[phase.name] = (scored, board)
        return board

    # ------------------------------------------------------------------ public episodes
    def public_episodes(self, v: SubmissionView) -> dict[tuple[str, int], EpisodeResult]:
        """The results of a scored submission's public episodes, from the channel's store
        (read once: a scored submission's results do not change)."""
        with self._lock:
            got = self._public.get(v.id)
        if got is not None:
            return got
        ch = self.channel
        public = [s.split for s in v.splits if s.public]
        name = ch.spec.campaign_name(ch.phase(v.phase))
        got = {}
        if (ch.data / "results.sqlite").is_file():
            with ch.store() as store:
                # One submission's rows only (store.results reads a whole campaign).
                for split, index, text in store.db.execute(
                        "SELECT split, idx, result FROM episodes WHERE campaign=? AND "
                        f"submission=? AND split IN ({', '.join('?' * len(public))})",
                        (name, v.id, *public)):
                    got[(split, int(index))] = EpisodeResult.model_validate_json(text)
        with self._lock:
            self._public[v.id] = got
        return got

    def episode_folder(self, result: EpisodeResult) -> Path | None:
        """The episode's folder where this process can read it (the runs of a runner
        beside the API, ``<data>/runs``), or None."""
        if not result.episode_dir or not _SAFE_ID.match(result.episode):
            return None
        folder = Path(result.episode_dir).resolve()
        runs = (self.channel.data / "runs").resolve()
        if not folder.is_relative_to(runs) or not (folder / "host" / "result.json").is_file():
            return None
        return folder

    def episode_page(self, team: str, sid: str, split: str, index: int) -> Response:
        ch = self.channel
        try:
            v = ch.view(sid, team=team)
        except ChannelError as e:
            return self.problem(str(e), e.status)
        summary = next((s for s in v.splits if s.split == split), None)
        if summary is None or not summary.public:
            return self.problem(f"{sid} has no public split {split!r}: episodes of hidden "
                                "splits are not shown", 404)
        result = self.public_episodes(v).get((split, index))
        folder = None if result is None else self.episode_folder(result)
        if result is None or folder is None:
            return self.problem(f"episode {split}/{index} of {sid} has no page here: its "
                                "folder is not on the channel's machine", 404)
        # Made once per eagc version (the viewer's pages change with it), then kept.
        out = ch.data / "pages" / "episodes" / __version__ / result.episode
        page = out / "index.html"
        with self._render:
            if not page.is_file():
                from orchestrator._viewer import write_episode_site

                try:
                    write_episode_site(folder, out, organizer=False)
                except Exception as e:  # noqa: BLE001 - a damaged folder: one line
                    log.warning("episode page of %s: %s", folder, e)
                    return self.problem(f"episode {split}/{index} of {sid}: its page could "
                                        f"not be made ({e})", 500)
        html = page.read_text(encoding="utf-8").replace(
            "<body>", '<body>\n<p><a href="/team">← your team\'s page</a></p>', 1)
        return HTMLResponse(html, headers=_headers(_EPISODE_CSP))


# ---------------------------------------------------------------------- what a row shows
def _headers(csp: str) -> dict[str, str]:
    return {"Content-Security-Policy": csp, "Cache-Control": "no-store",
            "Referrer-Policy": "no-referrer", "X-Content-Type-Options": "nosniff"}


def _short_image(image: str) -> str:
    repository, _, digest = image.partition("@")
    return f"{repository}@{digest[:19]}" if digest else repository


def _eta(eta_s: float | None, now: datetime) -> str:
    if eta_s is None:
        return "ETA once a first run has been timed"
    if eta_s < 60:
        return "ETA: within a minute"
    m = int(eta_s // 60)
    text = f"{m // 60} h {m % 60} min" if m >= 60 else f"{m} min"
    return f"ETA in about {text} ({utc_text(now + timedelta(seconds=eta_s))})"


def _row(v: SubmissionView, now: datetime) -> dict[str, Any]:
    """One line of the submissions table."""
    status = ""
    if v.state == S.QUEUED:
        status = f"position {v.position} · {_eta(v.eta_s, now)}"
    elif v.state == S.RUNNING:
        status = f"{v.episodes_done}/{v.episodes_planned} episodes"
    elif v.state == S.SCORED:
        status = (f"final {_num(v.final)} [{_num(v.final_low)}, {_num(v.final_high)}]")
    elif v.state in (S.FAILED, S.CANCELLED, S.RECEIVED, S.PREFLIGHT):
        status = v.reason
    return {"id": v.id, "image": _short_image(v.image), "full_image": v.image,
            "phase": v.phase, "state": str(v.state), "status": status, "note": v.note,
            "created": v.created_at, "charged": v.charged,
            "progress": (v.episodes_done, v.episodes_planned)
            if v.state == S.RUNNING else None}


def _split(v: SubmissionView, s: SplitSummary,
           public: dict[tuple[str, int], EpisodeResult]) -> dict[str, Any]:
    counts = Counter(e.status for e in s.verdicts)
    episodes = []
    if s.public:
        scores = s.scores or ()
        for i, e in enumerate(s.verdicts):
            result = public.get((s.split, e.index))
            episodes.append({"index": e.index, "status": e.status,
                             "score": scores[i] if i < len(scores) else None,
                             "page": f"/team/episodes/{v.id}/{s.split}/{e.index}"
                             if result is not None and result.episode_dir else None})
    return {"split": s.split, "score": s.score, "low": s.low, "high": s.high,
            "episodes": s.episodes, "public": s.public,
            "verdicts": ", ".join(f"{n} {status}" for status, n in sorted(counts.items())),
            "list": episodes}


def _num(v: float | None) -> str:
    return "—" if v is None else f"{v:.1f}"


# ---------------------------------------------------------------------- the routes
def mount(app: FastAPI) -> None:
    """Adds the team's pages to the API's app (``app.state.channel``)."""
    pages = Pages(app.state.channel)
    app.state.pages = pages
    https = ("https",)

    def cookie_team(request: Request) -> tuple[str | None, str]:
        token = request.cookies.get(COOKIE)
        if not token:
            return None, ""
        check = pages.channel.db.check_token(token)
        return check.team, check.problem

    def refused(problem: str) -> Response:
        r = pages.login_form(problem=problem, status=401)
        r.delete_cookie(COOKIE, path="/")
        return r

    @app.get("/", include_in_schema=False)
    def root() -> Response:
        return RedirectResponse("/team", status_code=303)

    @app.get("/login", include_in_schema=False)
    def login_form(request: Request) -> Response:
        team, _ = cookie_team(request)
        if team is not None:
            return RedirectResponse("/team", status_code=303)
        return pages.login_form()

    @app.post("/login", include_in_schema=False)
    async def login(request: Request) -> Response:
        form = parse_qs((await request.body()).decode("utf-8", "replace"),
                        max_num_fields=10)
        team = form.get("team", [""])[0].strip()
        token = form.get("token", [""])[0].strip()
        if not team or not token:
            return pages.login_form(team=team, problem="give your team's name and its token "
                                    "(the organizers sent them)", status=400)
        check = await run_in_threadpool(pages.channel.db.check_token, token)
        if check.team is None:
            return pages.login_form(team=team, problem=check.problem, status=401)
        if check.team != team:
            return pages.login_form(team=team, problem=f"this token is team {check.team}'s, "
                                    f"not {team!r}'s", status=401)
        r = RedirectResponse("/team", status_code=303)
        r.set_cookie(COOKIE, token, httponly=True, samesite="strict", path="/",
                     secure=request.url.scheme in https
                     or request.headers.get("x-forwarded-proto") in https)
        return r

    @app.get("/logout", include_in_schema=False)
    def logout() -> Response:
        r = RedirectResponse("/login", status_code=303)
        r.delete_cookie(COOKIE, path="/")
        return r

    @app.get("/team", include_in_schema=False)
    def team_page(request: Request) -> Response:
        team, problem = cookie_team(request)
        if team is None:
            return refused(problem) if problem else RedirectResponse("/login", 303)
        return pages.team_page(team)

    @app.get("/team/episodes/{sid}/{split}/{index}", include_in_schema=False)
    def episode(request: Request, sid: str, split: str, index: int) -> Response:
        team, problem = cookie_team(request)
        if team is None:
            return refused(problem) if problem else RedirectResponse("/login", 303)
        return pages.episode_page(team, sid, split, index)


def calendar_page(channel: Channel, phases: list[dict[str, Any]],
                  manifest_key: str | None = None) -> str:
    """The challenge's calendar: every window in UTC and Anywhere on Earth, each phase's
    rules and seed commitment, and the public key that will sign the final's manifest
    (public: nothing here is secret)."""
    now = channel.clock.utc()
    fingerprint = (None if manifest_key is None else
                   hashlib.sha256(manifest_key.encode("ascii")).hexdigest())
    return str(_env().get_template("calendar.html").render(
        challenge=channel.spec.name, track=channel.spec.track, phases=phases, now=now,
        manifest_key=manifest_key, fingerprint=fingerprint))
