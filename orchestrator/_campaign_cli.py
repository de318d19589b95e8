"""``eagc campaign …``: run, leaderboard, commit, reveal, status; and the local demo campaign.

Mount with ``app.add_typer(campaign_app, name="campaign")``. ``local_campaign`` is what
``eagc demo`` calls: the example agents of every installed track, on an embedded Ray.
Run standalone as ``python -m orchestrator._campaign_cli``.
"""

from __future__ import annotations

import logging
import os
import re
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

campaign_app = typer.Typer(
    help="Campaigns: run on Ray, resume, leaderboards, seed commitment and reveal.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)
out = Console(width=None if sys.stdout.isatty() else 160)  # piped: room for the columns
err = Console(stderr=True, width=None if sys.stderr.isatty() else 160)

CampaignArg = Annotated[Path, typer.Argument(help="The campaign file (YAML).")]
FORMATS = ("table", "csv", "json", "md")


@contextmanager
def _errors() -> Iterator[None]:
    """Known errors print as one clear message and exit 2, without a traceback."""
    from orchestrator._campaign import CampaignError
    from orchestrator._runtime import InfraError
    from orchestrator._seeds import SeedError
    from orchestrator._store import StoreError
    from plugins import PluginError
    from schemas import SchemaError

    try:
        yield
    except (SchemaError, CampaignError, SeedError, StoreError, PluginError, InfraError) as e:
        err.print(f"[bold red]error:[/] {e}", highlight=False)
        raise typer.Exit(2) from None


@contextmanager
def _driver_failures() -> Iterator[None]:
    """A campaign that had to stop: one message and its exit code (4 store, 5 Ray lost).

    With the Ray cluster gone the process leaves at once (``os._exit``): Ray's exit hooks
    would wait for the dead GCS."""
    from orchestrator._campaign import EXIT_STORE, DriverFailure
    from orchestrator._store import StoreError

    try:
        yield
    except DriverFailure as e:
        err.print(f"[bold red]error:[/] {e}", highlight=False)
        if e.exit_code != EXIT_STORE:
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(e.exit_code)
        raise typer.Exit(e.exit_code) from None
    except StoreError as e:
        err.print(f"[bold red]error:[/] {e}", highlight=False)
        raise typer.Exit(EXIT_STORE) from None


def _load(path: Path) -> Any:
    from orchestrator._campaign import load_campaign

    with _errors():
        return load_campaign(path)


def _store(spec: Any) -> Any:
    from orchestrator._campaign import store_path
    from orchestrator._store import ResultsStore

    path = store_path(spec)
    if not path.exists():
        err.print(f"[yellow]no results yet: {path} does not exist (run the campaign first)[/]")
        raise typer.Exit(1)
    return ResultsStore(path)


def _print_leaderboard(spec: Any, fmt: str = "table", output: Path | None = None) -> None:
    from orchestrator._leaderboard import build_leaderboard

    with _store(spec) as store:
        board = build_leaderboard(spec, store)
    if output is not None:
        output.write_text(board.render(fmt))
        err.print(f"leaderboard written to {output}")
    elif fmt == "table":
        out.print(board.to_rich())
    else:
        print(board.render(fmt), end="")


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
    from orchestrator._campaign import CampaignOptions, run_campaign

    spec = _load(campaign)
    options = CampaignOptions(address=address, workers=workers, metrics_port=metrics_port,
                              metrics_linger_s=metrics_linger,
                              progress=progress, retry_quarantined=retry_quarantined)
    with _errors(), _driver_failures():
        report = run_campaign(spec, options, console=err)
    err.print(f"{spec.name}: {report.committed} committed this run, {report.skipped} already "
              f"in the store, {report.retries} retried, {report.quarantined} quarantined, "
              f"{report.wall_s:.1f} s")
    _print_leaderboard(spec)
    if report.cancelled:
        raise typer.Exit(130)
    if report.quarantined:
        raise typer.Exit(3)


@campaign_app.command("rebuild-store")
def rebuild_store_cmd(campaign: CampaignArg) -> None:
    """Rebuild (or complete) the campaign's results in the store from its episode folders
    (each one's result.json) and events.jsonl; a damaged store file is moved aside first."""
    from orchestrator._rebuild import rebuild

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
) -> None:
    """The leaderboard (per split, final, tie-breaks) and the failed episodes."""
    if format not in FORMATS:
        raise typer.BadParameter(f"format must be one of {', '.join(FORMATS)}")
    _print_leaderboard(_load(campaign), format, output)


def _seeds(spec: Any) -> tuple[Any, list[Any]]:
    from orchestrator._seeds import load_secret, seed_list

    with _errors():
        secret = load_secret(spec)
    if secret.public:
        err.print("[yellow]no secret: these seeds derive from the campaign name (PUBLIC)[/]")
    return secret, seed_list(spec, secret)


@campaign_app.command("commit")
def commit_cmd(campaign: CampaignArg) -> None:
    """Print the seed commitment (SHA-256 of the seed list) to publish before the campaign."""
    from orchestrator._seeds import commitment

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
    from orchestrator._campaign import store_path
    from orchestrator._seeds import check_reveal, revealed_text

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
    from orchestrator._campaign import plan

    spec = _load(campaign)
    with _store(spec) as store:
        counts = store.counts(spec.name)
        held = store.quarantined(spec.name)
        done = store.done(spec.name)
    planned = plan(spec)
    table = Table(title=f"{spec.name} ({spec.track}, {spec.phase})", show_header=False)
    table.add_row("planned", str(len(planned)))
    for status, n in sorted(counts.items()):
        if status not in ("quarantined", "retries"):
            table.add_row(f"  {status}", str(n))
    table.add_row("quarantined", str(counts["quarantined"]))
    table.add_row("retries (infrastructure)", str(counts["retries"]))
    missing = [k for k in planned if k not in done and k not in {q.key for q in held}]
    table.add_row("missing", str(len(missing)))
    out.print(table)
    for q in held:
        out.print(f"[red]quarantined[/] {q.key} after {q.retries} retries: {q.message}")


# ---------------------------------------------------------------------------- the demo
DEMO_LIMITS: dict[str, dict[str, Any]] = {
    "sanity": {"memory_mb": 512},
    # The official budgets are minutes long: the demo scales them down and caps steps.
    "*": {"memory_mb": 1024, "time_scale": 0.02, "max_steps_per_stage": 100},
}


def example_agents_by_track(tracks: list[str]) -> dict[str, dict[str, Path]]:
    """Example agent images of each track: tag → folder.

    An ``examples/<folder>/Dockerfile`` belongs to a track when it says
    ``LABEL eagc.track=<track>``, or else when its folder name starts with ``<track>_``.
    """
    from orchestrator._images import example_agents

    found: dict[str, dict[str, Path]] = {t: {} for t in tracks}
    for tag, folder in example_agents().items():
        label = re.search(r"eagc\.track\s*=\s*\"?([A-Za-z0-9_.-]+)",
                          (folder / "Dockerfile").read_text())
        track = label.group(1) if label else next(
            (t for t in sorted(tracks, key=len, reverse=True) if folder.name.startswith(t + "_")),
            None)
        if track in found:
            found[track][tag] = folder
    return found


def _build_examples(examples: dict[str, dict[str, Path]], console: Console
                    ) -> dict[str, dict[str, Path]]:
    """Builds the example agents offline; an agent that fails to build is left out."""
    from orchestrator._docker import docker_client
    from orchestrator._images import ImageBuildError, build_agent_base, build_folder

    client = docker_client()
    built: dict[str, dict[str, Path]] = {}
    with console.status("building images offline (first time: about a minute)…"):
        build_agent_base(client, lambda m: console.print(f"[dim]{m}[/]"))
        for track, agents in examples.items():
            for tag, folder in agents.items():
                try:
                    build_folder(client, folder, tag, lambda m: console.print(f"[dim]{m}[/]"))
                except ImageBuildError as e:
                    first = str(e).splitlines()[0]
                    console.print(f"[yellow]skipping {tag}: it does not build ({first})[/]")
                    continue
                built.setdefault(track, {})[tag] = folder
    return built


def local_campaign(*, runtime: str = "auto", episodes: int = 2, workers: int | None = None,
                   output: Path = Path("runs"), console: Console | None = None) -> int:
    """A small local campaign per installed track with example agents, then its leaderboard.

    ``runtime``: ``docker`` (images built offline first), ``local`` (agents as plain
    processes, no sandbox) or ``auto`` (docker when an engine answers). Returns an exit code.
    """
    from orchestrator._campaign import CampaignOptions, check_campaign, run_campaign
    from plugins import PluginError, available_tracks, load_track
    from schemas import CampaignSpec, Limits, Split, Submission

    console = console or err
    if runtime == "auto":
        from orchestrator.cli import _docker_answers

        runtime = "docker" if _docker_answers() else "local"
        if runtime == "local":
            console.print("[yellow]No Docker engine answers: the example agents run as local "
                          "processes (no sandbox).[/]")
    tracks = []
    for name in available_tracks():
        try:
            tracks.append(load_track(name))
        except PluginError as e:
            console.print(f"[yellow]skipping track {name}: {e}[/]")
    examples = example_agents_by_track([t.name for t in tracks])
    if runtime == "docker" and any(examples.values()):
        examples = _build_examples(examples, console)
    workers = workers or max(1, min(2, os.cpu_count() or 1))
    stamp = time.strftime("%Y%m%d-%H%M%S")
    code = 0
    for plugin in tracks:
        agents = examples.get(plugin.name) or {}
        if not agents:
            console.print(f"[dim]track {plugin.name}: no example agent, skipped[/]")
            continue
        subs = tuple(
            Submission(team=folder.name, image=tag if runtime == "docker"
                       else f"python {folder / 'agent.py'}")
            for tag, folder in agents.items())
        splits = tuple(Split(name=s, weight=w, episodes=episodes)
                       for s, (w, _) in plugin.splits.items())
        limits = DEMO_LIMITS.get(plugin.name, DEMO_LIMITS["*"])
        spec = CampaignSpec(name=f"demo-{plugin.name}-{stamp}", track=plugin.name,
                            phase="local", splits=splits, submissions=subs,
                            limits=Limits(**limits), output=output, runtime=runtime)
        with _errors():
            check_campaign(spec, source=f"demo campaign of {plugin.name}")
            console.print(f"[bold]{spec.name}[/]: {len(subs)} agent(s) × "
                          f"{sum(s.episodes for s in splits)} episodes, {workers} worker(s), "
                          f"runtime {runtime}")
            report = run_campaign(spec, CampaignOptions(workers=workers), console=console)
        _print_leaderboard(spec)
        if report.cancelled:
            return 130
        code = code or (3 if report.quarantined else 0)
    return code


if __name__ == "__main__":
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    campaign_app()
