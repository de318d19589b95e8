"""``eagc campaign …``: run, plan, leaderboard, finalists, commit, reveal, status.

Mount with ``app.add_typer(campaign_app, name="campaign")``; run standalone as
``python -m orchestrator.cli.campaign``. Errors end in one line with the exit codes of
``orchestrator.cli.common``. ``eagc demo`` lives in ``orchestrator.cli.demo``.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from orchestrator.cli.common import EXIT_CODES_HELP, ExitCode, OneLineErrors

campaign_app = typer.Typer(
    cls=OneLineErrors,
    help="Campaigns: run on Ray, resume, leaderboards, seed commitment and reveal.",
    epilog=EXIT_CODES_HELP,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)
# Width: $COLUMNS when set, else the terminal's, else 80 (rich decides at each print).
out = Console()
err = Console(stderr=True)

CampaignArg = Annotated[Path, typer.Argument(help="The campaign file (YAML).")]
FORMATS = ("table", "csv", "json", "md")


@contextmanager
def _errors() -> Iterator[None]:
    """Kept for the commands that use it: every command's errors already end in one line
    (``OneLineErrors``), whatever raises them."""
    yield


@contextmanager
def _driver_failures() -> Iterator[None]:
    """A campaign that had to stop: one line and its exit code (5 store, 6 Ray lost).

    With the Ray cluster gone the process leaves at once (``os._exit``): Ray's exit hooks
    would wait for the dead GCS."""
    import os
    import sys

    from orchestrator._campaign.driver_io import EXIT_STORE, DriverFailure
    from orchestrator._results.store import StoreError
    from orchestrator.cli.common import say_error

    try:
        yield
    except DriverFailure as e:
        say_error(str(e))
        if e.exit_code != EXIT_STORE:
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(e.exit_code)
        raise typer.Exit(e.exit_code) from None
    except StoreError as e:
        say_error(str(e))
        raise typer.Exit(EXIT_STORE) from None


def _load(path: Path) -> Any:
    from orchestrator._campaign.spec import load_campaign

    with _errors():
        return load_campaign(path)


def _store(spec: Any) -> Any:
    from orchestrator._campaign.spec import store_path
    from orchestrator._results.store import ResultsStore

    path = store_path(spec)
    if not path.exists():
        err.print(f"[yellow]no results yet: {path} does not exist (run the campaign first)[/]",
                  highlight=False)
        raise typer.Exit(ExitCode.ERROR)
    return ResultsStore(path)


def _print_leaderboard(spec: Any, fmt: str = "table", output: Path | None = None,
                       team: str | None = None) -> None:
    from orchestrator._results.leaderboard import build_leaderboard
    from orchestrator._results.team_report import team_report

    with _store(spec) as store:
        board = build_leaderboard(spec, store)
        report = None if team is None else team_report(spec, store, board, team)
    if report is not None:
        text = report.to_json() + "\n" if fmt == "json" else report.to_text()
    else:
        text = board.render(fmt)
    if output is not None:
        output.write_text(text)
        err.print(f"leaderboard written to {output}", highlight=False)
    else:
        print(text, end="")


def _short(path: Path) -> str:
    """``path`` relative to the working folder when it is under it (shorter to read)."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def where_results(spec: Any, source: Path | None) -> list[str]:
    """Where a campaign's results are, and how to see them again: one item a line, each
    command's comment on a line of its own above it (``# …``, so that a command copies
    whole), so that the lines fit 80 columns unless a path alone is longer."""
    from orchestrator._campaign.spec import campaign_dir, store_path

    name = _short(source) if source else "CAMPAIGN.yaml"
    return [f"results of {spec.name} (SQLite, one row per episode):",
            f"  {_short(store_path(spec))}",
            f"episode folders and events.jsonl: {_short(campaign_dir(spec))}/",
            "see again:",
            f"  eagc leaderboard {name}",
            f"  eagc status {name}",
            "  # one team's episodes",
            f"  eagc leaderboard {name} --team NAME",
            "  # as web pages: the episodes' timelines, frames and score cards",
            f"  eagc report {name} --out report"]


@campaign_app.command("run")
def run_cmd(
    campaign: CampaignArg,
    address: Annotated[str | None, typer.Option(
        help="An existing Ray cluster ('auto', or host:port). Default: an embedded Ray.")] = None,
    metrics_port: Annotated[int | None, typer.Option(
        help="Serve Prometheus metrics on this port while the campaign runs.")] = None,
    metrics_linger: Annotated[float, typer.Option(
        help="Keep serving metrics this many seconds after the end (a last scrape).")] = 0.0,
    workers: Annotated[int, typer.Option(
        min=1, help="Containers at a time on the embedded Ray (its eagc_slot count).")] = 1,
    retry_quarantined: Annotated[bool, typer.Option(
        help="Run quarantined episodes again (an organizer's decision).")] = False,
    progress: Annotated[bool, typer.Option(help="Show the progress bar.")] = True,
) -> None:
    """Run a campaign, or resume it: only episodes missing from the store are run."""
    from orchestrator._campaign.driver import run_campaign
    from orchestrator._campaign.driver_io import CampaignOptions

    spec = _load(campaign)
    options = CampaignOptions(address=address, workers=workers, metrics_port=metrics_port,
                              metrics_linger_s=metrics_linger,
                              progress=progress, retry_quarantined=retry_quarantined)
    with _errors(), _driver_failures():
        report = run_campaign(spec, options, console=err)
    err.print(f"{spec.name}: {report.committed} committed this run, {report.skipped} already "
              f"in the store, {report.retries} retried, {report.quarantined} quarantined, "
              f"{report.wall_s:.1f} s", highlight=False)
    _print_leaderboard(spec)
    for line in where_results(spec, campaign):
        err.print(line, highlight=False, soft_wrap=True)
    if report.cancelled:
        raise typer.Exit(ExitCode.CANCELLED)
    if report.quarantined:
        raise typer.Exit(ExitCode.INFRA)


@campaign_app.command("plan")
def plan_cmd(
    campaign: CampaignArg,
    pilot: Annotated[Path | None, typer.Option(
        help="A pilot campaign file whose results give the paired spread and the episode "
             "durations (default: the track's reference spread and the stage budgets).")
    ] = None,
    resolve: Annotated[float, typer.Option(
        help="The gap (final points, 0-100) two teams must be separated at.")] = 10.0,
    confidence: Annotated[float, typer.Option(min=0.5, max=0.999)] = 0.95,
    power: Annotated[float, typer.Option(
        help="How often a true gap of --resolve is separated.", min=0.5, max=0.99)] = 0.8,
    workers: Annotated[int, typer.Option(help="Workers the campaign will run on.",
                                         min=1)] = 1,
    fmt: Annotated[str, typer.Option("--format", help="table or json")] = "table",
) -> None:
    """Size a campaign before running it: episodes per split to separate two teams
    RESOLVE points apart, and the episode-hours and wall time that costs."""
    from orchestrator._campaign.plan import plan_campaign, results_by_team
    from orchestrator._errors import UsageError

    if fmt not in ("table", "json"):
        raise UsageError(f"--format {fmt!r}: table or json")
    spec = _load(campaign)
    results, name = None, None
    if pilot is not None:
        pilot_spec = _load(pilot)
        if pilot_spec.track != spec.track:
            raise UsageError(f"the pilot {pilot_spec.name} is a {pilot_spec.track} campaign, "
                             f"not {spec.track}")
        with _store(pilot_spec) as store:
            results, name = results_by_team(pilot_spec, store), pilot_spec.name
    plan = plan_campaign(spec, resolve=resolve, workers=workers, pilot=results,
                         pilot_name=name, confidence=confidence, power=power)
    print(plan.to_json() if fmt == "json" else plan.to_text(), end="\n" if fmt == "json"
          else "")


@campaign_app.command("rebuild-store")
def rebuild_store_cmd(campaign: CampaignArg) -> None:
    """Rebuild (or complete) the campaign's results in the store from its episode folders
    (each one's result.json) and events.jsonl; a damaged store file is moved aside first."""
    from orchestrator._campaign.rebuild import rebuild

    spec = _load(campaign)
    with _errors():
        report = rebuild(spec)
    if report.moved_aside is not None:
        err.print(f"the damaged store was moved to {report.moved_aside}")
    err.print(f"{spec.name}: {report.results_read} result.json read, {report.committed} "
              f"committed, {report.already} already there, {report.attempts} attempts, "
              f"{report.quarantined} quarantined")
    for what, items in (("not named in events.jsonl", report.unattributed),
                        ("unreadable", report.unreadable)):
        if items:
            err.print(f"[yellow]{len(items)} result(s) {what}[/]: {', '.join(items[:5])}")


@campaign_app.command("leaderboard")
def leaderboard_cmd(
    campaign: CampaignArg,
    format: Annotated[str, typer.Option("--format", "-f", help="table, csv, json or md.")
                      ] = "table",
    output: Annotated[Path | None, typer.Option(help="Write to this file.")] = None,
    team: Annotated[str | None, typer.Option(
        help="One team's report: its row and every one of its episodes (verdict, stage "
             "reached, limit hit, its agent's last lines); table or json.")] = None,
) -> None:
    """The leaderboard (per split, final, tie-breaks) and the failed episodes, or one
    team's own report (--team). Text fits $COLUMNS (80 by default)."""
    from orchestrator._errors import UsageError

    if format not in FORMATS:
        raise UsageError(f"--format {format!r}: one of {', '.join(FORMATS)}")
    if team is not None and format not in ("table", "json"):
        raise UsageError(f"--team reports are table or json, not {format!r}")
    _print_leaderboard(_load(campaign), format, output, team)


@campaign_app.command("finalists")
def finalists_cmd(
    campaign: CampaignArg,
    k: Annotated[int, typer.Option("--k", min=1, help="How many finalists the rules name.")],
    baseline: Annotated[list[str] | None, typer.Option(
        "--baseline", help="A reference team: shown, but not compared and not in the cut "
                           "(repeat for several).")] = None,
    cap: Annotated[int | None, typer.Option(
        min=1, help="At most this many finalists when more qualify (default 2K).")] = None,
    format: Annotated[str, typer.Option("--format", "-f", help="table or json.")] = "table",
) -> None:
    """The finalists at K: every team whose best rank is K or better (no team cut by a
    coin flip), the first 2K by the point estimate if more qualify; who is in, who is out
    and why, and whom the ranges could not separate at the cut."""
    from difflib import get_close_matches

    from orchestrator._errors import UsageError
    from orchestrator._results.finalists import finalists
    from orchestrator._results.leaderboard import build_leaderboard

    if format not in ("table", "json"):
        raise UsageError(f"--format {format!r}: table or json")
    spec = _load(campaign)
    teams = [s.team for s in spec.submissions]
    for b in baseline or []:
        if b not in teams:
            near = get_close_matches(b, teams, n=1)
            raise UsageError(f"--baseline {b!r} is not a team of {spec.name}"
                             + (f". Did you mean {near[0]!r}?" if near else ""))
    if cap is not None and cap < k:
        raise UsageError(f"--cap {cap} is below --k {k}")
    with _store(spec) as store:
        board = build_leaderboard(spec, store, baselines=baseline or ())
    cut = finalists(board, k, baselines=baseline or (), cap=cap)
    print(cut.to_json() if format == "json" else cut.to_text(), end="\n" if format == "json"
          else "")


def _seeds(spec: Any) -> tuple[Any, list[Any]]:
    from orchestrator._campaign.seeds import load_secret, seed_list

    with _errors():
        secret = load_secret(spec)
    if secret.public:
        err.print("[yellow]no secret: these seeds derive from the campaign name (PUBLIC)[/]")
    return secret, seed_list(spec, secret)


@campaign_app.command("commit")
def commit_cmd(campaign: CampaignArg) -> None:
    """Print the seed commitment (SHA-256 of the seed list) to publish before the campaign."""
    from orchestrator._campaign.seeds import commitment

    spec = _load(campaign)
    secret, seeds = _seeds(spec)
    err.print(f"{len(seeds)} seeds of {spec.name}, secret from {secret.source}")
    print(commitment(spec, seeds))


@campaign_app.command("reveal")
def reveal_cmd(
    campaign: CampaignArg,
    expect: Annotated[str | None, typer.Option(
        help="The published commitment (default: the one in the results store).")] = None,
    check: Annotated[Path | None, typer.Option(
        help="Check a published seed list (no secret needed) instead of computing it.")] = None,
) -> None:
    """Print the seed list and check it against the published commitment."""
    from orchestrator._campaign.seeds import check_reveal, revealed_text
    from orchestrator._campaign.spec import store_path

    spec = _load(campaign)
    if expect is None and store_path(spec).exists():
        with _store(spec) as store:
            expect = store.commitment(spec.name)
    if check is not None:
        text = check.read_text()
    else:
        _, seeds = _seeds(spec)
        text = revealed_text(spec, seeds)
        print(text, end="")
    if expect is None:
        err.print("[yellow]no commitment to check against (give --expect)[/]")
        raise typer.Exit(1)
    names = [line.split(" ")[0] for line in text.splitlines()]
    planned = [f"{spec.name}/{s.name}/{i}" for s in spec.splits for i in range(s.episodes)]
    if names != planned:
        err.print("[bold red]the list does not name this campaign's episodes in order[/]")
        raise typer.Exit(1)
    if not check_reveal(text, expect):
        err.print(f"[bold red]MISMATCH[/]: the seed list does not hash to {expect}")
        raise typer.Exit(1)
    err.print(f"[green]✓[/] {len(names)} seeds match the commitment {expect}")


@campaign_app.command("status")
def status_cmd(campaign: CampaignArg) -> None:
    """Episodes planned, committed by status, quarantined, retried and missing."""
    from orchestrator._campaign.spec import plan

    spec = _load(campaign)
    with _store(spec) as store:
        counts = store.counts(spec.name)
        held = store.quarantined(spec.name)
        done = store.done(spec.name)
    planned = plan(spec)
    table = Table(title=f"{spec.name} ({spec.track}, {spec.phase})", show_header=False)
    table.add_row("planned", str(len(planned)))
    for status, n in sorted(counts.by_status.items()):
        table.add_row(f"  {status.value}", str(n))
    table.add_row("quarantined", str(counts.quarantined))
    table.add_row(f"retries (infrastructure; {spec.retries} allowed)", str(counts.retries))
    missing = [k for k in planned if k not in done and k not in {q.key for q in held}]
    table.add_row("missing", str(len(missing)))
    out.print(table)
    for q in held:
        how = f"retried {q.retries} time{'s' if q.retries != 1 else ''}" if q.retries else (
            "not retried")
        out.print(f"[red]quarantined[/] {q.key}: {how} (the campaign allows {spec.retries}): "
                  f"{q.message}", highlight=False)


if __name__ == "__main__":
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    campaign_app()
