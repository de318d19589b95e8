"""The channel's HTTP API (FastAPI on uvicorn).

Teams authenticate with ``Authorization: Bearer <token>``; the runner with its own token
(``<data>/runner.token``). The registry sends Docker's token requests to ``/auth/token``
with HTTP Basic credentials: a team's name and token (what ``eagc submit`` gives the
engine), or ``runner`` and the runner's token. Every refusal is one line in ``detail``
saying what was wrong and what to do; a submission of another team is "not found", exactly
as one that does not exist.

    GET  /api/v1/whoami                     the team, the open phase, the registry
    POST /api/v1/submissions                submit an image of the team's repository
    GET  /api/v1/submissions[/{id}]         the team's submissions
    POST /api/v1/submissions/{id}/cancel    cancel one of the team's, waiting or running
    POST /api/v1/submissions/{id}/select    the one the board counts (phase counts: selected)
    GET  /api/v1/phases                     the calendar (public): windows, rules, commitments
    GET  /api/v1/phases/{p}/seeds           a closed phase's seeds (public), as committed
    GET  /calendar                          the calendar as a page
    GET  /api/v1/findings?phase=P           the team's audit findings and their rulings
    POST /api/v1/findings/{id}/appeal       appeal a ruling within the appeal window
    PUT  /api/v1/final/files/{name}         a finalist's report or statement, to freeze
    POST /api/v1/final/freeze               freeze a submission with the uploaded files
    GET  /api/v1/final                      what the team has frozen, with its hashes
    GET  /api/v1/final/key                  the manifest's public key (PEM, public)
    GET  /api/v1/quota                      what the team has left today, when it resets
    GET  /api/v1/board                      the open phase's board (teams' latest scored)
    POST /api/v1/runner/claim               runner: take a pre-flight or a run
    GET  /api/v1/runner/campaign/{phase}    runner: the campaign a phase's submissions play
    GET  /api/v1/runner/preflight/{phase}   runner: the phase's pre-flight settings
    POST /api/v1/runner/{id}/heartbeat      runner: renew the lease, report progress
    POST /api/v1/runner/{id}/report         runner: the pre-flight's or the run's outcome
    GET  /auth/token                        Docker registry token endpoint
    GET  /login, /team, …                   the team's pages (``pages``)
    GET  /metrics                           Prometheus (orchestrator/_channel/metrics.py)
"""

from __future__ import annotations

import base64
import hashlib
import hmac
import logging
import os
from collections.abc import Callable
from dataclasses import asdict
from typing import Annotated, Any

from fastapi import Depends, FastAPI, Header, HTTPException, Query, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from starlette.exceptions import HTTPException as StarletteHTTPException

from orchestrator._channel import pages
from orchestrator._channel.channel import Channel, aoe_text, utc_text
from orchestrator._channel.db import ChannelError
from orchestrator._channel.metrics import ChannelMetrics
from orchestrator._channel.pages import calendar_page
from orchestrator._channel.registry import RUNNER, grant
from schemas import (
    Claim,
    FreezeRequest,
    Outcome,
    Progress,
    QuotaView,
    SubmissionView,
    SubmitRequest,
    Work,
)

log = logging.getLogger("eagc.channel")
#: Largest request body accepted (a disclosure is the largest thing a team sends), but
#: for the files of a freeze (``FILES``), up to the final's own cap.
MAX_BODY = 256 * 1024
FILES = "/api/v1/final/files/"


def _bearer(authorization: str | None) -> str:
    if not authorization or not authorization.lower().startswith("bearer "):
        raise HTTPException(401, "no token: log in first (eagc login URL --team NAME "
                            "--token TOKEN)")
    return authorization[7:].strip()


def _channel(request: Request) -> Channel:
    channel: Channel = request.app.state.channel
    return channel


def _team(request: Request, authorization: Annotated[str | None, Header()] = None) -> str:
    check = _channel(request).db.check_token(_bearer(authorization))
    if check.team is None:
        raise HTTPException(401, check.problem)
    return check.team


def _runner(request: Request, authorization: Annotated[str | None, Header()] = None) -> None:
    if not hmac.compare_digest(_bearer(authorization), _channel(request).runner_token):
        raise HTTPException(401, "not the runner's token (<data>/runner.token)")


def body_limit(path: str) -> int:
    """The largest body accepted on ``path``."""
    from orchestrator._channel.final import MAX_FILE_BYTES

    return MAX_FILE_BYTES if path.startswith(FILES) else MAX_BODY


def _over(limit: int) -> str:
    return (f"request body over {limit // 2**20} MiB" if limit >= 2**20 else
            f"request body over {limit // 1024} KiB")


class BodyCap:
    """Refuses a request whose body is over ``limit`` bytes, however it is sent: by its
    Content-Length at once, a chunked one as soon as the bytes received pass the limit (so
    nothing past it is ever held in memory): the 413 is sent there and then, the app is
    told the client left, and whatever it answers after is dropped. The refusal is
    recorded off the event loop."""

    def __init__(self, app: Any, limit: Callable[[str], int], record: Any) -> None:
        self.app, self.limit, self.record = app, limit, record

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        length = dict(scope["headers"]).get(b"content-length")
        limit = self.limit(scope["path"])
        if length is not None and (not length.isdigit() or int(length) > limit):
            await self._refuse(scope, receive, send)
            return
        seen = 0
        refused = False

        async def counted() -> Any:
            nonlocal seen, refused
            if refused:
                return {"type": "http.disconnect"}
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > limit:
                    refused = True
                    scope["eagc.refused"] = True  # what the app answers next is not kept
                    await self._refuse(scope, receive, send)
                    return {"type": "http.disconnect"}
            return message

        async def sending(message: Any) -> None:
            if not refused:
                await send(message)

        await self.app(scope, counted, sending)

    async def _refuse(self, scope: Any, receive: Any, send: Any) -> None:
        from starlette.concurrency import run_in_threadpool

        client = scope.get("client") or ("?", 0)
        over = _over(self.limit(scope["path"]))
        await run_in_threadpool(self.record, str(client[0]), scope["method"], scope["path"],
                                over)
        await JSONResponse({"detail": over}, status_code=413,
                           headers={"Connection": "close"})(scope, receive, send)


Team = Annotated[str, Depends(_team)]
Runner = Annotated[None, Depends(_runner)]


def manifest_pem(channel: Channel) -> str | None:
    """The final's manifest key (PEM), made once when the challenge has a final phase;
    read from its public file (``keys/manifest.pub``) once made."""
    if not any(p.kind == "final" for p in channel.spec.phases):
        return None
    pub = channel.data / "keys" / "manifest.pub"
    if not pub.is_file():
        from orchestrator._channel.final import signing_key

        signing_key(channel.data / "keys")
    return pub.read_text(encoding="ascii")


def create_app(channel: Channel) -> FastAPI:
    app = FastAPI(title=f"eagc channel: {channel.spec.name}", version="1",
                  docs_url=None, redoc_url=None)
    app.state.channel = channel
    metrics = ChannelMetrics(channel)

    @app.get("/metrics")
    def prometheus() -> Response:
        return Response(metrics.exposition(),
                        media_type="text/plain; version=0.0.4; charset=utf-8")

    def refuse(request: Request, status: int, detail: str,
               headers: dict[str, str] | None = None) -> JSONResponse:
        """The one-line JSON refusal, kept in the database with who asked what (called
        on a worker thread: the event loop never waits for the disk)."""
        client = request.client.host if request.client else "?"
        if not request.scope.get("eagc.refused"):
            channel.db.record_refusal(client, request.method, request.url.path, status,
                                      detail)
        return JSONResponse({"detail": detail}, status_code=status, headers=headers)

    # Plain functions: Starlette runs them on its thread pool.
    @app.exception_handler(ChannelError)
    def channel_error(request: Request, e: ChannelError) -> JSONResponse:
        return refuse(request, e.status, str(e))

    @app.exception_handler(StarletteHTTPException)
    def http_error(request: Request, e: StarletteHTTPException) -> JSONResponse:
        return refuse(request, e.status_code, str(e.detail), dict(e.headers or {}))

    @app.exception_handler(RequestValidationError)
    def bad_request(request: Request, e: RequestValidationError) -> JSONResponse:
        first = e.errors()[0] if e.errors() else {}
        where = ".".join(str(p) for p in first.get("loc", ()) if p != "body")
        return refuse(request, 422, f"malformed request: {where or 'body'}: "
                      f"{first.get('msg', 'invalid')}")

    def too_large(client: str, method: str, path: str, why: str) -> None:
        channel.db.record_refusal(client, method, path, 413, why)

    app.add_middleware(BodyCap, limit=body_limit, record=too_large)

    @app.get("/api/v1/whoami")
    def whoami(who: Team) -> dict[str, Any]:
        try:
            phase = channel.open_phase()
            open_phase: dict[str, Any] | None = {"name": phase.name, "kind": phase.kind}
        except ChannelError as e:
            open_phase, why = None, str(e)
        else:
            why = ""
        used, cap = channel.storage(who)
        return {"team": who, "challenge": channel.spec.name, "track": channel.spec.track,
                "storage_bytes": used, "storage_cap_bytes": cap,
                "registry": channel.registry_address(), "repository": f"teams/{who}",
                "phase": open_phase, "closed_because": why,
                "phases": [{"name": w.phase.name, "kind": w.phase.kind,
                            "opens": utc_text(w.opens),
                            "closes": None if w.closes is None else utc_text(w.closes)}
                           for w in channel.windows()]}

    @app.post("/api/v1/submissions", status_code=201)
    def submit(req: SubmitRequest, who: Team) -> SubmissionView:
        return channel.submit(who, req)

    @app.get("/api/v1/submissions")
    def submissions(who: Team) -> list[SubmissionView]:
        return channel.submissions(who)

    @app.get("/api/v1/submissions/{sid}")
    def submission(sid: str, who: Team) -> SubmissionView:
        return channel.view(sid, team=who)

    @app.post("/api/v1/submissions/{sid}/cancel")
    def cancel(sid: str, who: Team) -> SubmissionView:
        channel.cancel(sid, team=who)
        return channel.view(sid, team=who)

    @app.get("/api/v1/quota")
    def quota(who: Team) -> QuotaView:
        return channel.quota(who)

    @app.get("/api/v1/board")
    def board(who: Team, phase: str | None = None) -> dict[str, Any]:
        """The board of the open phase (or ``phase``), as its ``board`` setting allows: all
        rows (public), the team's own row (team), or nothing (organizers)."""
        p = channel.phase(phase) if phase else channel.open_phase()
        if p.board == "organizers":
            raise ChannelError(f"the board of phase {p.name} is for the organizers until "
                               "its results are released", 403)
        b = channel.board(p)
        rows = [] if b is None else [
            {"rank": r.rank, "ranks": r.ranks, "team": r.team, "final": r.final,
             "low": r.interval.low if r.interval else None,
             "high": r.interval.high if r.interval else None, "episodes": r.episodes}
            for r in b.rows if p.board == "public" or r.team == who]
        return {"phase": p.name, "board": p.board, "counts": p.counts,
                "teams": 0 if b is None else len(b.rows), "rows": rows}

    @app.get("/api/v1/findings")
    def team_findings(who: Team, phase: str) -> list[dict[str, Any]]:
        """The audit's findings of the team in ``phase``, with their rulings."""
        from orchestrator._channel.release import findings

        keep = ("id", "detail", "ruling", "reason", "ruled_at", "appeal")
        return [{k: f[k] for k in keep} for f in findings(channel, channel.phase(phase).name,
                                                         who)]

    @app.post("/api/v1/findings/{finding}/appeal")
    def appeal(finding: int, body: dict[str, str], who: Team) -> dict[str, str]:
        from orchestrator._channel.release import appeal as do_appeal

        do_appeal(channel, finding, who, str(body.get("text", "")))
        return {"finding": str(finding), "state": "appealed: waits for a new ruling"}

    @app.put(FILES + "{name}", status_code=201)
    async def upload(name: str, request: Request, who: Team) -> dict[str, Any]:
        """A finalist's technical report (``report.pdf``, ``report.md``) or open-source
        statement (``statement.yaml``, ``statement.json``), kept until it freezes."""
        from starlette.concurrency import run_in_threadpool
        from starlette.requests import ClientDisconnect

        from orchestrator._channel.final import UPLOADS, may_freeze, upload_folder

        if name not in UPLOADS:
            raise ChannelError(f"upload one of {', '.join(UPLOADS)}, not {name!r}", 404)
        await run_in_threadpool(may_freeze, channel, who)
        folder = upload_folder(channel, who)
        folder.mkdir(parents=True, exist_ok=True, mode=0o700)
        part, digest, size = folder / f".{name}.part", hashlib.sha256(), 0
        try:
            with part.open("wb") as f:
                async for chunk in request.stream():
                    digest.update(chunk)
                    size += len(chunk)
                    f.write(chunk)
        except ClientDisconnect:
            part.unlink(missing_ok=True)
            raise ChannelError(f"the upload of {name} was cut off", 400) from None
        os.replace(part, folder / name)
        return {"name": name, "bytes": size, "sha256": digest.hexdigest()}

    @app.post("/api/v1/final/freeze")
    def freeze(req: FreezeRequest, who: Team) -> dict[str, Any]:
        """Freezes the team's submission with the files it uploaded (``final.freeze``)."""
        from orchestrator._channel.final import freeze_uploaded

        return asdict(freeze_uploaded(channel, who, req.submission, statement=req.statement,
                                      phase=req.phase))

    @app.get("/api/v1/final")
    def frozen(who: Team) -> list[dict[str, Any]]:
        """What the team has frozen in each final phase, with each file's SHA-256."""
        from orchestrator._channel.final import frozen as frozen_in

        return [asdict(f) for p in channel.spec.phases if p.kind == "final"
                for f in frozen_in(channel, p.name) if f.team == who]

    @app.get("/api/v1/final/key")
    def manifest_key() -> Response:
        """The public key that signs the final's manifest (PEM): public before the final,
        so anyone can check the manifest once it is published."""
        pem = manifest_pem(channel)
        if pem is None:
            raise ChannelError("this challenge has no final phase, so no manifest key", 404)
        return Response(pem, media_type="application/x-pem-file")

    @app.post("/api/v1/submissions/{sid}/select")
    def select(sid: str, who: Team) -> SubmissionView:
        channel.select(sid, who)
        return channel.view(sid, team=who)

    @app.get("/api/v1/phases")
    def phases() -> list[dict[str, Any]]:
        """The calendar, public: each phase's window in UTC and AoE, its rules and its
        seed commitment (published before it opens; its seeds after it closes)."""
        return [{"name": w.phase.name, "kind": w.phase.kind,
                 "opens": utc_text(w.opens), "opens_aoe": aoe_text(w.opens),
                 "closes": None if w.closes is None else utc_text(w.closes),
                 "closes_aoe": None if w.closes is None else aoe_text(w.closes),
                 "who": w.phase.who, "board": w.phase.board, "counts": w.phase.counts,
                 "resolves": (channel.sizing(w.phase) or {}).get("resolve"),
                 "commitment": channel.seeds(w.phase)[0]} for w in channel.windows()]

    @app.get("/api/v1/phases/{phase}/seeds")
    def revealed(phase: str) -> Response:
        return Response(channel.reveal(channel.phase(phase)), media_type="text/plain")

    @app.get("/calendar", include_in_schema=False)
    def calendar() -> Response:
        from fastapi.responses import HTMLResponse

        return HTMLResponse(calendar_page(channel, phases(), manifest_pem(channel)), headers={
            "Content-Security-Policy": "default-src 'none'; style-src 'unsafe-inline'; "
            "img-src data:; base-uri 'none'; frame-ancestors 'none'"})

    @app.post("/api/v1/runner/claim")
    def claim(c: Claim, _: Runner) -> Response:
        work: Work | None = channel.claim(c.runner, c.kind)
        if work is None:
            return Response(status_code=204)
        return JSONResponse(work.model_dump(mode="json"))

    @app.get("/api/v1/runner/campaign/{phase}")
    def campaign(phase: str, _: Runner) -> dict[str, Any]:
        spec = channel.campaign(channel.phase(phase), channel.data / "runs")
        return spec.model_dump(mode="json")

    @app.get("/api/v1/runner/preflight/{phase}")
    def preflight(phase: str, _: Runner) -> dict[str, Any]:
        return channel.phase(phase).preflight.model_dump(mode="json")

    @app.post("/api/v1/runner/{sid}/heartbeat", status_code=204)
    def heartbeat(sid: str, p: Progress, _: Runner) -> None:
        channel.heartbeat(sid, p)

    @app.post("/api/v1/runner/{sid}/report")
    def report(sid: str, o: Outcome, _: Runner) -> SubmissionView:
        view = channel.report(sid, o)
        metrics.observe(o.kind, o.wall_s)
        return view

    @app.get("/auth/token")
    def token(request: Request, service: str = "", account: str = "",
              scope: Annotated[list[str] | None, Query()] = None) -> dict[str, Any]:
        who = _basic(request.headers.get("authorization"), channel)
        access = grant(who, scope or [])
        if who != RUNNER and any("push" in a["actions"] for a in access):
            used, cap = channel.storage(who)
            if used >= cap:  # the registry then answers the push with "denied"
                log.warning("team %s is at its storage cap (%d of %d bytes)", who, used, cap)
                access = [{**a, "actions": [x for x in a["actions"] if x != "push"]}
                          for a in access]
        return channel.keys.token(who, access)

    pages.mount(app)
    return app


def _basic(header: str | None, channel: Channel) -> str:
    """The registry's caller from HTTP Basic credentials: a team, or the runner."""
    if not header or not header.lower().startswith("basic "):
        raise HTTPException(401, "credentials required: `eagc submit` logs the engine in "
                            "for you", headers={"WWW-Authenticate": 'Basic realm="eagc"'})
    try:
        user, _, password = base64.b64decode(header[6:]).decode().partition(":")
    except ValueError:
        raise HTTPException(401, "malformed Basic credentials") from None
    if user == RUNNER:
        if hmac.compare_digest(password, channel.runner_token):
            return RUNNER
        raise HTTPException(401, "not the runner's token")
    check = channel.db.check_token(password)
    if check.team is None:
        raise HTTPException(401, check.problem)
    if check.team != user:
        raise HTTPException(401, f"this token is team {check.team}'s, not {user!r}'s")
    return check.team
