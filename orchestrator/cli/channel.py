"""The submission channel's commands (``docs/channel.md``).

Organizers: ``eagc challenge serve|teams|runner``. Teams: ``eagc login``, ``eagc submit``,
``eagc submissions``. Every refusal is one line saying what was wrong and what to do.
"""

from __future__ import annotations

import json
import os
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from orchestrator.cli.common import EXIT_CODES_HELP, OneLineErrors
from schemas import SubmissionState, SubmissionView

challenge_app = typer.Typer(
    cls=OneLineErrors, no_args_is_help=True, pretty_exceptions_enable=False,
    epilog=EXIT_CODES_HELP,
    help="Organizers: the submission channel (API, registry, runner) and its teams.")
teams_app = typer.Typer(cls=OneLineErrors, no_args_is_help=True,
                        pretty_exceptions_enable=False,
                        help="The channel's teams: add, list, make a new token.")
challenge_app.add_typer(teams_app, name="teams")
out = Console()
err = Console(stderr=True)

DataOpt = Annotated[Path, typer.Option("--data", help="The channel's data folder.")]
DEFAULT_DATA = Path("channel")
#: The example files (found from the installed package, as `eagc demo` finds them).
DEMOS = Path(__file__).resolve().parents[2] / "examples" / "campaigns"


@challenge_app.command("serve")
def serve_cmd(
    challenge: Annotated[Path, typer.Argument(help="CHALLENGE.yaml")],
    data: DataOpt = DEFAULT_DATA,
    port: Annotated[int, typer.Option(help="The API's port (0: a free one).")] = 8480,
    host: Annotated[str, typer.Option(help="Where the API and the registry listen.")
                    ] = "127.0.0.1",
    registry_port: Annotated[int, typer.Option(help="The registry's port (0: a free one).")
                             ] = 0,
    workers: Annotated[int, typer.Option(help="Episodes the runner plays at a time.")] = 1,
    address: Annotated[str | None, typer.Option(help="A Ray head for the runner's campaigns."
                                                )] = None,
    runner: Annotated[bool, typer.Option(help="Start a runner beside the API.")] = True,
    clock_speed: Annotated[float, typer.Option(hidden=True, help="Channel seconds per real "
                                               "second (rehearsals).")] = 1.0,
) -> None:
    """Start the channel: the API and team pages, the registry and a runner."""
    from orchestrator._channel.db import Clock
    from orchestrator._channel.serve import load_challenge, serve

    spec = load_challenge(challenge)
    clock = None
    if clock_speed != 1.0:  # a compressed clock; a restart resumes the one it kept
        kept = None
        if (data / "channel.sqlite").is_file():
            from orchestrator._channel.serve import open_db

            kept = open_db(data).meta("clock")
        clock = Clock.of(kept) if kept else Clock(speed=clock_speed)
    serve(spec, data, host=host, port=port, registry_port=registry_port, workers=workers,
          address=address, runner=runner, clock=clock,
          say=lambda s: err.print(s, highlight=False, soft_wrap=True))


@challenge_app.command("runner")
def runner_cmd(
    url: Annotated[str, typer.Argument(help="The channel's URL.")],
    token_file: Annotated[Path, typer.Option(help="The runner's token (<data>/runner.token).")],
    runs: Annotated[Path, typer.Option(help="Where campaigns and pre-flights write.")
                    ] = Path("runs/channel"),
    workers: Annotated[int, typer.Option(help="Episodes played at a time.")] = 1,
    address: Annotated[str | None, typer.Option(help="A Ray head (default: embedded).")
                       ] = None,
) -> None:
    """Take submissions from a channel and run them (a runner on another machine)."""
    from orchestrator._channel.runner import Runner

    r = Runner(url=url, token=token_file.read_text().strip(), runs=runs, address=address,
               workers=workers, say=lambda s: err.print(s, highlight=False, soft_wrap=True))
    err.print(f"runner {r.name}: taking work from {url}", highlight=False)
    r.serve()


@teams_app.command("add")
def teams_add(name: Annotated[str, typer.Argument(help="The team's name.")],
              data: DataOpt = DEFAULT_DATA) -> None:
    """Add a team and print its first token (alone on the last line)."""
    import re

    from orchestrator._channel.db import ChannelError
    from orchestrator._channel.serve import open_db
    from schemas import TEAM_NAME

    if not re.match(TEAM_NAME, name):
        raise ChannelError(f"team {name!r}: lower-case letters, digits, '-' and '_', at most "
                           "39, starting with a letter or digit")
    db = open_db(data)
    if not db.add_team(name):
        raise ChannelError(f"team {name} exists already: `eagc challenge teams token {name}` "
                           "makes it a new token")
    _print_token(db, name)


@teams_app.command("list")
def teams_list(data: DataOpt = DEFAULT_DATA) -> None:
    """The channel's teams."""
    from orchestrator._channel.serve import open_db

    db = open_db(data)
    for name, created, disabled in db.teams():
        n = len(db.rows(team=name))
        out.print(f"{name:<24} added {datetime.fromtimestamp(created, UTC):%Y-%m-%d %H:%M} UTC"
                  f"  {n} submission{'s' if n != 1 else ''}{'  DISABLED' if disabled else ''}",
                  highlight=False)


@teams_app.command("token")
def teams_token(name: Annotated[str, typer.Argument(help="The team's name.")],
                data: DataOpt = DEFAULT_DATA) -> None:
    """Make a team a new token (its old one stops working); the token is the last line."""
    from orchestrator._channel.serve import open_db

    _print_token(open_db(data), name)


def _print_token(db: object, team: str) -> None:
    from orchestrator._channel.db import ChannelDB

    assert isinstance(db, ChannelDB)
    days = float(db.meta("token_days") or 60)
    token, expires = db.new_token(team, days)
    err.print(f"team {team}: a new token, valid until "
              f"{datetime.fromtimestamp(expires, UTC):%Y-%m-%d %H:%M} UTC (shown once; "
              "any earlier token of the team is revoked):", highlight=False)
    print(token)


# ---------------------------------------------------------------------- teams' commands
def login_cmd(
    url: Annotated[str, typer.Argument(help="The channel's URL (from the organizers).")],
    team: Annotated[str, typer.Option(help="Your team's name.")],
    token: Annotated[str, typer.Option(help="Your team's token.")],
) -> None:
    """Log in to a challenge's channel (kept in your user's config, mode 0600)."""
    from orchestrator._channel.client import ChannelClient, Login, save_login

    who = ChannelClient(url, token).whoami()
    if who["team"] != team:
        from orchestrator._channel.db import ChannelError

        raise ChannelError(f"this token is team {who['team']}'s, not {team}'s")
    path = save_login(Login(url, team, token))
    phase = who.get("phase")
    out.print(f"logged in to {who['challenge']} ({who['track']}) as team {team}; "
              + (f"phase {phase['name']} is open" if phase else who["closed_because"])
              + f"\n(kept in {path})", highlight=False)


def submit_cmd(
    image: Annotated[str, typer.Argument(help="Your local image (pushed for you), or one "
                                         "already pushed: teams/<team>/<name>[:tag|@digest]")],
    note: Annotated[str, typer.Option(help="A note kept with the submission.")] = "",
    disclosure: Annotated[Path | None, typer.Option(help="Your resource disclosure (YAML "
                                                    "or JSON).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
) -> None:
    """Push your image to the challenge's registry and submit it by its digest."""
    from orchestrator._channel.client import load_login, submit

    login = load_login()
    view = submit(image, login, note=note, disclosure=disclosure,
                  say=lambda s: err.print(s, highlight=False))
    if as_json:
        print(view.model_dump_json())
        return
    out.print(f"submitted {view.id}: {_short(view.image)}", highlight=False)
    out.print("it runs its pre-flight first; follow it with", highlight=False)
    out.print(f"  eagc submissions {view.id} --follow", highlight=False)


def submissions_cmd(
    sid: Annotated[str | None, typer.Argument(help="One submission (default: all yours).")
                   ] = None,
    follow: Annotated[bool, typer.Option(help="Watch it until it is scored, failed or "
                                         "cancelled.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="JSON (one object for one "
                                          "submission).")] = False,
    quota: Annotated[bool, typer.Option("--quota", help="What you have left today, and "
                                        "when it resets.")] = False,
    cancel: Annotated[bool, typer.Option("--cancel", help="Cancel submission ID (waiting "
                                         "or running); its slot is free at once.")] = False,
    select: Annotated[bool, typer.Option("--select", help="Make submission ID the one the "
                                         "board counts (phases that count 'selected').")
                      ] = False,
) -> None:
    """Your team's submissions: state, queue position, ETA, scores; --quota, --cancel."""
    from orchestrator._channel.client import ChannelClient, load_login
    from orchestrator._errors import UsageError

    login = load_login()
    client = ChannelClient(login.url, login.token)
    if quota:
        q = client.quota()
        if as_json:
            print(q.model_dump_json())
            return
        out.print(f"team {q.team}, phase {q.phase}, {q.day} (UTC): {q.left} of "
                  f"{q.per_day + q.granted} submissions left"
                  + (f" ({q.granted} granted)" if q.granted else "")
                  + f"; {q.refunded} refunded", highlight=False)
        out.print(f"  resets {q.resets_at:%Y-%m-%d %H:%M} UTC; {q.active} of {q.concurrent} "
                  f"waiting or running; {q.failed_preflights} of "
                  f"{q.failed_preflights_per_day} failed pre-flights", highlight=False)
        return
    if select:
        if sid is None:
            raise UsageError("--select needs the submission's ID")
        client.call("POST", f"/api/v1/submissions/{sid}/select")
        out.print(f"{sid} is the submission the board counts", highlight=False)
        return
    if cancel:
        if sid is None:
            raise UsageError("--cancel needs the submission's ID")
        view = client.cancel(sid)
        out.print(f"{view.id} cancelled", highlight=False)
        return
    if sid is None:
        views = client.submissions()
        if as_json:
            print(json.dumps([v.model_dump(mode="json") for v in views]))
            return
        if not views:
            out.print("no submissions yet: `eagc submit IMAGE`", highlight=False)
        for v in views:
            out.print(_line(v), highlight=False)
        return
    view = client.submission(sid)
    shown = ""
    while True:
        now = _line(view)
        if follow and now != shown and not as_json:
            out.print(f"{datetime.now(UTC):%H:%M:%S}  {now}", highlight=False)
            shown = now
        if not follow or view.state.final:
            break
        time.sleep(2.0)
        view = client.submission(sid)
    if as_json:
        print(view.model_dump_json())
    else:
        _details(view)


def freeze_team_cmd(
    submission: Annotated[str, typer.Argument(help="Your submission for the final "
                                              "(queued, running or scored).")],
    report: Annotated[Path, typer.Option("--report", help="Your technical report (PDF or "
                                         "Markdown).")],
    statement: Annotated[Path | None, typer.Option(
        "--statement", help="Your open-source statement (YAML or JSON), optional.")] = None,
    phase: Annotated[str | None, typer.Option(
        "--phase", help="The final phase (default: the challenge's final).")] = None,
) -> None:
    """Finalists: freeze a submission, its report and statement before the deadline."""
    from orchestrator._channel.client import freeze, load_login

    got = freeze(submission, report, load_login(), statement=statement, phase=phase)
    out.print(f"froze {got['submission']} for the final {got['phase']}: "
              f"{_short(got['repository'] + '@' + got['digest'])}", highlight=False)
    for kind, entry in got["files"].items():
        out.print(f"  {kind:<10} sha256 {entry['sha256'][:16]}…", highlight=False)
    out.print("a later freeze before the deadline replaces this one; the manifest signed "
              "at the deadline names exactly these (check it with `eagc challenge "
              "verify`)", highlight=False)


def _line(v: SubmissionView) -> str:
    what = {SubmissionState.QUEUED: (f"position {v.position}"
                                     + (f", starts in ~{_dur(v.eta_s)}" if v.eta_s is not None
                                        else ", ETA after the first run is measured")),
            SubmissionState.RUNNING: f"{v.episodes_done}/{v.episodes_planned} episodes",
            SubmissionState.SCORED: (f"final {v.final:.1f} [{v.final_low:.1f}, "
                                     f"{v.final_high:.1f}]" if v.final is not None
                                     else "scored"),
            }.get(v.state, v.reason)
    return f"{v.id}  {v.phase:<10} {v.state.value:<9} {what}"


def _short(image: str) -> str:
    """``repo@sha256:<12 hex>``: the digest's first 12 hex digits (``--json`` has it all)."""
    repo, _, digest = image.partition("@")
    return f"{repo}@{digest[:19]}" if digest else repo


def _dur(s: float) -> str:
    return f"{s / 60:.0f} min" if s >= 90 else f"{s:.0f} s"


def _details(v: SubmissionView) -> None:
    out.print(_line(v), highlight=False)
    out.print(f"  image {_short(v.image)}", highlight=False)
    if v.preflight:
        out.print(f"  pre-flight {v.preflight}", highlight=False)
    if v.state == SubmissionState.FAILED:
        out.print(f"  why: {v.reason}", highlight=False)
    for s in v.splits:
        kinds: dict[str, int] = {}
        for e in s.verdicts:
            kinds[e.status] = kinds.get(e.status, 0) + 1
        verdicts = ", ".join(f"{n} {k}" for k, n in sorted(kinds.items()))
        out.print(f"  {s.split:<10} {s.score:5.1f} [{s.low:.1f}, {s.high:.1f}]  "
                  f"{s.episodes} episodes: {verdicts}", highlight=False)
    for h in v.history:
        detail = _short(h.detail) if h.state == SubmissionState.RECEIVED else h.detail
        out.print(f"  {h.at:%m-%d %H:%M:%S}  {h.state.value:<9} {detail}", highlight=False)


# ---------------------------------------------------------------------- the organizer's hand
WhyOpt = Annotated[str, typer.Option("--why", help="Why (kept with who and when, and shown "
                                     "in the submission's history).")]


def _who() -> str:
    import getpass

    return os.environ.get("EAGC_ORGANIZER") or getpass.getuser()


@challenge_app.command("queue")
def queue_cmd(data: DataOpt = DEFAULT_DATA) -> None:
    """Every submission waiting or running, in the order they will run."""
    from orchestrator._channel.serve import open_channel

    ch = open_channel(data)
    active = [r for r in ch.db.rows() if not r.state.final]
    if not active:
        out.print("nothing waits or runs", highlight=False)
    for r in sorted(active, key=lambda r: (r.state != SubmissionState.RUNNING,
                                           r.queued_at or r.created_at)):
        v = ch.view(r.id, team=None)
        out.print(f"{v.team:<12} {_line(v)}", highlight=False)
    if ch.db.meta("paused"):
        out.print(f"PAUSED: {ch.db.meta('paused')}", highlight=False)


@challenge_app.command("finalists")
def finalists_cmd(phase: Annotated[str, typer.Argument(help="A phase that admits its "
                                                       "finalists only.")],
                  teams: Annotated[list[str], typer.Argument(help="The finalists.")],
                  why: WhyOpt, data: DataOpt = DEFAULT_DATA) -> None:
    """Name the teams a finalists-only phase admits."""
    from orchestrator._channel.serve import open_channel

    ch = open_channel(data)
    ch.set_finalists(ch.phase(phase), teams, who=_who(), why=why)
    out.print(f"phase {phase} admits {', '.join(sorted(teams))}", highlight=False)


@challenge_app.command("audit")
def audit_cmd(phase: Annotated[str, typer.Argument(help="The phase.")],
              top: Annotated[int, typer.Option(help="Audit every team the board allows "
                                               "within this rank.", min=1)],
              why: WhyOpt, data: DataOpt = DEFAULT_DATA,
              rerun: Annotated[int, typer.Option(help="Episodes of each team run again.",
                                                 min=0)] = 0) -> None:
    """Audit the phase's top teams; each finding then waits for a ruling."""
    from orchestrator._channel.release import audit_phase
    from orchestrator._channel.serve import open_channel

    ch = open_channel(data)
    found = audit_phase(ch, ch.phase(phase), top, rerun=rerun, who=_who(),
                        say=lambda s: err.print(s, highlight=False))
    for f in found:
        out.print(f"{f['team']}: {f['detail']}", highlight=False, soft_wrap=True)
    out.print(f"{len(found)} finding{'s' if len(found) != 1 else ''} to rule on "
              "(eagc challenge rule ID accept|rerun|disqualify --why …)", highlight=False)


@challenge_app.command("rule")
def rule_cmd(finding: Annotated[int, typer.Argument(help="The finding's number.")],
             ruling: Annotated[str, typer.Argument(help="accept, rerun or disqualify")],
             why: WhyOpt, data: DataOpt = DEFAULT_DATA) -> None:
    """Rule on an audit finding (the team may appeal within the appeal window)."""
    from orchestrator._channel.release import rule
    from orchestrator._channel.serve import open_channel

    rule(open_channel(data), finding, ruling, who=_who(), why=why)
    out.print(f"finding {finding}: {ruling}", highlight=False)


@challenge_app.command("release")
def release_cmd(phase: Annotated[str, typer.Argument(help="The phase.")],
                to: Annotated[Path, typer.Option("--out", help="Where the pages go.")],
                why: WhyOpt, data: DataOpt = DEFAULT_DATA) -> None:
    """Release a phase's results: each team's report, then the public board; refused
    while a finding waits for a ruling or an appeal window is open."""
    from orchestrator._channel.release import release
    from orchestrator._channel.serve import open_channel

    ch = open_channel(data)
    for path in release(ch, ch.phase(phase), to, who=_who(), why=why):
        out.print(f"  {path}", highlight=False)
    out.print(f"released phase {phase}: the public board is {to / 'board.md'}",
              highlight=False)


@challenge_app.command("plan")
def plan_cmd(
    phase: Annotated[str, typer.Argument(help="The phase to size.")],
    source: Annotated[str, typer.Option("--from", help="The previous phase, whose paired "
                                        "spreads and episode times it measures.")],
    resolve: Annotated[float, typer.Option(help="The gap (points) to separate.", min=0.1)],
    data: DataOpt = DEFAULT_DATA,
    workers: Annotated[int, typer.Option(help="Workers the runner has.", min=1)] = 1,
    approve: Annotated[bool, typer.Option(help="Make it the phase's episodes (before it "
                                          "opens).")] = False,
    cost_cap: Annotated[float, typer.Option("--cost-cap", help="Wall hours the approved "
                                            "plan may take at most.")] = 48.0,
    why: Annotated[str, typer.Option("--why", help="Why (kept with the approval).")] = "",
) -> None:
    """Size a phase from the previous phase's results: the episodes that separate two teams
    RESOLVE points apart, and their cost; --approve makes them the phase's."""
    from orchestrator._campaign.plan import plan_campaign
    from orchestrator._channel.serve import open_channel
    from schemas import Submission

    ch = open_channel(data)
    target, before = ch.phase(phase), ch.phase(source)
    pilot = ch.pilot(before)
    teams = max(2, len(ch.db.teams()) if target.who == "all" else len(ch.finalists(target)))
    spec = ch.campaign(target, ch.data / "runs", tuple(
        Submission(team=f"t{i}", image="none") for i in range(teams)))
    plan = plan_campaign(spec, resolve=resolve, workers=workers, pilot=pilot,
                         pilot_name=f"phase {source}")
    out.print(plan.to_text(), highlight=False, end="")
    if approve:
        ch.approve_sizing(target, plan, cost_cap_h=cost_cap, who=_who(),
                          why=why or "sized from data")
        out.print(f"approved: phase {phase} plays {plan.episodes_per_team} episodes a "
                  f"submission, resolving {resolve:g} points", highlight=False)


@challenge_app.command("rehearse")
def rehearse_cmd(
    output: Annotated[Path, typer.Option(help="Where its files, manifest and public pages "
                                         "go.")] = Path("runs/rehearsal"),
) -> None:
    """Play the whole calendar with the example teams in minutes: a real channel,
    registry and Ray on a compressed clock (docs/challenge.md)."""
    from orchestrator._channel.rehearse import Rehearsal
    from orchestrator._images.build import build_agent_base, build_folder, example_agents
    from orchestrator._runtimes.docker import docker_client

    image = "eagc/sanity-agent:latest"
    client = docker_client()
    with err.status("building the example image offline (first time: a few minutes)…"):
        build_agent_base(client, lambda _: None)
        build_folder(client, example_agents()[image], image, lambda _: None)
    disclosure = DEMOS / "baselines.disclosure.yaml"
    r = Rehearsal(output.resolve(), image, disclosure,
                  say=lambda s: err.print(s, highlight=False, soft_wrap=True))
    try:
        r.start()
        summary = r.run()
    finally:
        r.stop()
    for phase, rows in summary["boards"].items():
        out.print(f"phase {phase}: " + ", ".join(
            f"{x['rank']}. {x['team']} ({x['ranks']})" for x in rows), highlight=False)
    out.print(f"finalists: {', '.join(summary['finalists'])}", highlight=False)
    out.print(f"audit: {summary['findings']} finding(s), each ruled on", highlight=False)
    out.print(f"manifest: {summary['manifest']} "
              f"({'verified' if summary['verified'] else 'NOT verified'})", highlight=False)
    out.print(f"public board: {summary['public']}", highlight=False)


@challenge_app.command("cancel")
def cancel_cmd(sid: Annotated[str, typer.Argument(help="The submission.")], why: WhyOpt,
               data: DataOpt = DEFAULT_DATA) -> None:
    """Cancel a submission (free: its charge is refunded)."""
    from orchestrator._channel.serve import open_channel

    open_channel(data).cancel(sid, team=None, who=_who(), why=why)
    out.print(f"{sid} cancelled and refunded", highlight=False)


@challenge_app.command("rerun")
def rerun_cmd(sid: Annotated[str, typer.Argument(help="The submission.")], why: WhyOpt,
              data: DataOpt = DEFAULT_DATA) -> None:
    """Run a submission's image again, as a new free submission."""
    from orchestrator._channel.serve import open_channel

    new = open_channel(data).rerun(sid, who=_who(), why=why)
    out.print(f"{sid} runs again as {new} (free)", highlight=False)


@challenge_app.command("refund")
def refund_cmd(
    since: Annotated[str, typer.Option("--from", help="Start of the incident (UTC, ISO).")],
    until: Annotated[str, typer.Option("--to", help="Its end (UTC, ISO).")],
    why: WhyOpt, data: DataOpt = DEFAULT_DATA,
) -> None:
    """Refund every submission that failed inside an incident window."""
    from orchestrator._channel.serve import open_channel
    from schemas import parse_when

    ch = open_channel(data)
    start, end = (parse_when(x, ch.started).timestamp() for x in (since, until))
    ids = ch.refund_window(start, end, who=_who(), why=why)
    out.print(f"refunded {len(ids)} submission{'s' if len(ids) != 1 else ''}"
              + (f": {', '.join(ids)}" if ids else ""), highlight=False)


@challenge_app.command("grant")
def grant_cmd(team: Annotated[str, typer.Argument(help="The team.")],
              n: Annotated[int, typer.Argument(help="Extra submissions today.", min=1)],
              why: WhyOpt, data: DataOpt = DEFAULT_DATA) -> None:
    """Grant a team more submissions today."""
    from orchestrator._channel.serve import open_channel

    open_channel(data).grant(team, n, who=_who(), why=why)
    out.print(f"team {team}: {n} more submission{'s' if n != 1 else ''} today",
              highlight=False)


@challenge_app.command("pause")
def pause_cmd(why: WhyOpt, data: DataOpt = DEFAULT_DATA,
              resume: Annotated[bool, typer.Option(help="Resume instead.")] = False) -> None:
    """Pause the channel (no submission accepted, no work handed out), or --resume it."""
    from orchestrator._channel.serve import open_channel

    open_channel(data).pause(not resume, who=_who(), why=why)
    out.print("resumed" if resume else "paused: submissions are refused with your reason",
              highlight=False)


@challenge_app.command("disable")
def disable_cmd(team: Annotated[str, typer.Argument(help="The team.")], why: WhyOpt,
                data: DataOpt = DEFAULT_DATA,
                enable: Annotated[bool, typer.Option(help="Enable it again.")] = False) -> None:
    """Disable a team (its token stops working), or --enable it again."""
    from orchestrator._channel.serve import open_channel

    open_channel(data).disable(team, not enable, who=_who(), why=why)
    out.print(f"team {team} {'enabled' if enable else 'disabled'}", highlight=False)


@challenge_app.command("log")
def log_cmd(data: DataOpt = DEFAULT_DATA,
            refusals: Annotated[int, typer.Option(help="How many of the latest refused "
                                                  "requests to show.")] = 20) -> None:
    """The organizers' actions (who, when, what, why) and the latest refused requests."""
    from orchestrator._channel.serve import open_db

    db = open_db(data)
    for at, who, action, target, why in db.actions():
        out.print(f"{datetime.fromtimestamp(at, UTC):%m-%d %H:%M:%S}  {who:<10} {action:<8} "
                  f"{target}: {why}", highlight=False, soft_wrap=True)
    for at, client, method, path, status, detail in db.refusals(refusals):
        out.print(f"{datetime.fromtimestamp(at, UTC):%m-%d %H:%M:%S}  refused {status} "
                  f"{method} {path} from {client}: {detail}", highlight=False, soft_wrap=True)


@challenge_app.command("gc")
def gc_cmd(why: WhyOpt, data: DataOpt = DEFAULT_DATA) -> None:
    """Remove from the registry every image no submission names (the channel stopped)."""
    from orchestrator._channel.db import ChannelError
    from orchestrator._channel.serve import open_channel, serving
    from orchestrator._channel.storage import collect

    if serving(data):
        raise ChannelError("the channel is serving: stop it first (the registry's garbage "
                           "collection must not run beside pushes)")
    ch = open_channel(data)
    keep = {(r.repository, r.digest) for r in ch.db.rows()}
    got = collect(data / "registry" / "storage", data / "registry" / "config.yml", keep)
    with ch.db.tx() as db:
        ch.db.record_action(db, _who(), "gc", f"{got.manifests} images", why)
    out.print(f"removed {got.manifests} image{'s' if got.manifests != 1 else ''} no "
              f"submission names; {got.freed_bytes / 2**20:,.1f} MB freed", highlight=False)


@challenge_app.command("backup")
def backup_cmd(to: Annotated[Path, typer.Option("--to", help="The backup's folder.")],
               data: DataOpt = DEFAULT_DATA) -> None:
    """A consistent copy of the channel, serving or not (docs/channel.md, Backups)."""
    from orchestrator._channel.serve import open_db
    from orchestrator._channel.storage import backup

    open_db(data).close()  # a channel's folder, or one line saying it is not
    for path in backup(data, to):
        out.print(f"  {path}", highlight=False)
    out.print(f"backed up {data} to {to}", highlight=False)


# The frozen final (orchestrator/cli/final.py).
from orchestrator.cli.final import freeze_cmd, manifest_cmd, verify_cmd  # noqa: E402

challenge_app.command("freeze")(freeze_cmd)
challenge_app.command("manifest")(manifest_cmd)
challenge_app.command("verify")(verify_cmd)
