"""The ``eagc`` command line.

Every command ends in one line when something is wrong, never a traceback, with the exit
codes of ``orchestrator.cli.common`` (shown by ``eagc --help`` and in docs/commands.md).
"""

from __future__ import annotations

import difflib
import logging
import os
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console

from orchestrator._errors import UsageError
from orchestrator.cli.audit import AUDIT_CODES, audit_cmd
from orchestrator.cli.campaign import campaign_app, leaderboard_cmd, status_cmd
from orchestrator.cli.channel import (
    challenge_app,
    freeze_team_cmd,
    login_cmd,
    submissions_cmd,
    submit_cmd,
)
from orchestrator.cli.check_files import CHECK_FILES_CODES, check_files_cmd
from orchestrator.cli.common import (
    EXIT_CODES_HELP,
    SEED_RANGE,
    ExitCode,
    OneLineErrors,
    check_split,
    check_track,
    episode_folder,
    episode_log,
    episode_spinner,
    limits_of,
)
from orchestrator.cli.report import REPORT_CODES, report_cmd

app = typer.Typer(
    cls=OneLineErrors,
    help="eagc: the evaluation system of the EAGC 2026 World Model Challenge.",
    epilog=EXIT_CODES_HELP,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)
images_app = typer.Typer(cls=OneLineErrors,
                         help="Build the base, agent-base and example images offline.")
app.add_typer(images_app, name="images")
app.add_typer(campaign_app, name="campaign")
app.add_typer(challenge_app, name="challenge")
# Top-level aliases of the commands an organizer types most.
app.command("leaderboard", help="Alias of `eagc campaign leaderboard`.")(leaderboard_cmd)
app.command("status", help="Alias of `eagc campaign status`.")(status_cmd)
app.command("audit", epilog=AUDIT_CODES)(audit_cmd)
app.command("check-files", epilog=CHECK_FILES_CODES)(check_files_cmd)
app.command("report", epilog=REPORT_CODES)(report_cmd)
# The submission channel, for teams (docs/channel.md).
app.command("login")(login_cmd)
app.command("submit")(submit_cmd)
app.command("submissions")(submissions_cmd)
app.command("freeze")(freeze_team_cmd)


def _print_version(value: bool) -> None:
    if value:
        import orchestrator

        print(f"eagc {orchestrator.__version__}")
        raise typer.Exit()


@app.callback()
def _options(
    version: Annotated[bool, typer.Option(
        "--version", callback=_print_version, is_eager=True,
        help="Print eagc's version (what changed for teams: CHANGELOG.md) and exit.")] = False,
) -> None:
    # No docstring: the app's help stays the one given to typer.Typer above.
    pass


# Width: $COLUMNS when set, else the terminal's, else 80 (rich decides at each print).
console = Console()
#: Progress and warnings: stderr, so that --json output stays clean.
notes = Console(stderr=True)

#: Where ``eagc preview`` writes when ``--out`` is not given.
PREVIEWS = Path("runs") / "previews"


def preview_name(track: str, split: str, seed: int) -> str:
    """A preview's file name, one scheme for every track: ``<track>-<split>-seed<N>.png``."""
    return f"{track}-{split}-seed{seed}.png"
RUN_EPISODE_CODES = ("Exit codes: 0 the episode completed; 3 infrastructure failure (not "
                     "the agent's fault: run it again); 4 the agent failed (crash, timeout, "
                     "OOM, protocol, bad files, no start); 1 an error, on one line; 2 usage "
                     "error (unknown track or split, bad seed).")

SeedOpt = Annotated[int, typer.Option(help="Scenario seed (public: for local tests).",
                                      **SEED_RANGE)]


def local_command(image: str) -> str:
    """What ``--runtime local`` runs for an example image (``eagc/track1-heuristic``, with
    or without ``:latest``): its folder's agent.py; anything else is a command line."""
    from orchestrator._images.build import example_agents

    agents = example_agents()
    folder = agents.get(image) or agents.get(f"{image}:latest")
    if folder is None:
        return image  # already a command line
    return f"python {folder / 'agent.py'}"


def check_image(image: str, client: Any) -> None:
    """UsageError, with a "Did you mean" among the engine's eagc/* images, when the
    Docker engine has no image ``image`` (the sandbox never pulls)."""
    import docker

    try:
        client.images.get(image)
        return
    except docker.errors.ImageNotFound:
        pass
    except docker.errors.APIError:
        return  # the episode says what the engine answered
    tags = [t for i in client.images.list() for t in i.tags if t.startswith("eagc/")]
    names = tags + [t.removesuffix(":latest") for t in tags if t.endswith(":latest")]
    hint = difflib.get_close_matches(image, names, n=1, cutoff=0.5)
    raise UsageError(f"no image {image!r} here."
                     + (f" Did you mean {hint[0]!r}?" if hint else " See `docker images`."))


def _runtime(name: str):  # noqa: ANN202
    if name == "docker":
        from orchestrator._runtimes.docker import DockerRuntime

        return DockerRuntime()
    if name != "local":
        raise UsageError(f"no runtime named {name!r}: docker, or local (development only)")
    from orchestrator._runtimes.local import WARNING, LocalProcessRuntime

    notes.print(f"[bold yellow]{WARNING}[/]")
    return LocalProcessRuntime(quiet=True)


def _episode_exit(result: Any) -> ExitCode:
    """0 completed, 3 infrastructure failure, 4 agent failure."""
    kind = result.status.failure_kind
    return ExitCode.OK if kind is None else ExitCode.INFRA if kind == "infra" else ExitCode.AGENT


TIME_SCALE_HELP = ("Multiplies every stage budget (0-1], and the 120 s startup budget, "
                   "never below 60 s (time for a container to start and load its "
                   "models).")


def _run_one(track: str, image: str, runtime: str, seed: int, split: str, time_scale: float,
             max_steps: int | None, memory_mb: int, cpus: float, runs_dir: Path,
             as_json: bool) -> int:
    from orchestrator._episode.worker import EpisodeSpec, run_episode
    from orchestrator._results.score_card import print_result, where_line

    plugin = check_track(track)
    check_split(plugin, split)
    limits = limits_of(time_scale=time_scale, max_steps_per_stage=max_steps,
                       memory_mb=memory_mb, cpus=cpus)
    if runtime == "local":
        image = local_command(image)
    spec = EpisodeSpec(track=track, image=image, seed=seed, split=split, limits=limits,
                       runs_dir=runs_dir)
    agent_runtime = _runtime(runtime)
    with episode_spinner(notes.status, f"one {track} episode ({runtime})", limits, plugin):
        result = run_episode(spec, agent_runtime)
    if as_json:
        print(result.model_dump_json(indent=2))
    else:
        print_result(result, console)
        console.print(where_line(result), highlight=False)
    return _episode_exit(result)


@app.command("run-episode", epilog=RUN_EPISODE_CODES)
def run_episode_cmd(
    track: Annotated[str, typer.Argument(help="Track name, e.g. sanity.")],
    image: Annotated[str, typer.Option(help="Agent image (docker) or command (local).")],
    runtime: Annotated[str, typer.Option(help="docker, or local (development only).")] = "docker",
    seed: SeedOpt = 0,
    split: Annotated[str, typer.Option(help="A split of the track (standard, challenge, …).")
                     ] = "standard",
    time_scale: Annotated[float, typer.Option(help=TIME_SCALE_HELP)
                          ] = 1.0,
    max_steps: Annotated[int | None, typer.Option(help="Step cap per stage.")] = None,
    memory_mb: Annotated[int, typer.Option()] = 2048,
    cpus: Annotated[float, typer.Option()] = 1.0,
    runs_dir: Annotated[Path, typer.Option(help="Where episode folders go.")] = Path("runs"),
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as JSON.")] = False,
) -> None:
    """Run one episode of a track against an agent and print its score card."""
    raise typer.Exit(_run_one(track, image, runtime, seed, split, time_scale, max_steps,
                              memory_mb, cpus, runs_dir, as_json))


@app.command()
def demo(
    runtime: Annotated[str, typer.Option(help="auto, docker or local.")] = "auto",
    track: Annotated[list[str] | None, typer.Option(
        help="Only this track (repeat for several). Default: every installed track.")] = None,
    workers: Annotated[int | None, typer.Option(min=1, help="Containers at a time.")] = None,
    output: Annotated[Path | None, typer.Option(
        help="Results folder (default: each demo file's own, runs/demo).")] = None,
) -> None:
    """Run the demo campaigns: every baseline of every track, fixed seeds.

    The campaigns are examples/campaigns/demo_<track>.yaml, run on an embedded Ray, in
    containers when a Docker engine answers (images built offline first), otherwise as
    local processes. Each ends with its leaderboard and where its results are. Run again:
    the stored results are shown, nothing is rerun.
    """
    from orchestrator.cli.demo import run_demo

    if runtime not in ("auto", "docker", "local"):
        raise UsageError(f"no runtime named {runtime!r}: auto, docker or local")
    raise typer.Exit(run_demo(runtime=runtime, tracks=track or None, workers=workers,
                              output=output, console=notes))


@app.command("test", epilog="Exit codes: 0 the container meets the contract; 4 it does not; "
                            "3 infrastructure failure; 1 an error; 2 usage error.")
def test_agent(
    image: Annotated[str, typer.Argument(help="Your image (a command with --runtime local).")],
    track: Annotated[str, typer.Option(help="Track to test against.")] = "sanity",
    runtime: Annotated[str, typer.Option(help="docker (the sandbox) or local.")] = "docker",
    seed: Annotated[int, typer.Option(help="A public seed.", **SEED_RANGE)] = 1,
    split: Annotated[str, typer.Option(help="A split of the track.")] = "standard",
    time_scale: Annotated[float, typer.Option(help=TIME_SCALE_HELP)
                          ] = 0.1,
    memory_mb: Annotated[int, typer.Option()] = 2048,
    runs_dir: Annotated[Path, typer.Option()] = Path("runs"),
) -> None:
    """Check your container against the contract: one real episode in the sandbox."""
    from rich.table import Table

    from orchestrator._episode.agentcheck import contract_checks, verdict
    from orchestrator._episode.worker import EpisodeSpec, run_episode
    from orchestrator._results.score_card import print_result, where_line

    plugin = check_track(track)
    check_split(plugin, split)
    if runtime == "local":
        image = local_command(image)
    elif runtime == "docker" and len(image.split()) > 1:
        raise UsageError(f"{image!r} is a command, not an image: use --runtime local")
    limits = limits_of(time_scale=time_scale, memory_mb=memory_mb)
    spec = EpisodeSpec(track=track, image=image, seed=seed, split=split, runs_dir=runs_dir,
                       limits=limits)
    agent_runtime = _runtime(runtime)
    if runtime == "docker":
        check_image(image, agent_runtime.client)
    with episode_spinner(notes.status, f"one {track} episode with {image} ({runtime})",
                         limits, plugin):
        result = run_episode(spec, agent_runtime)
    print_result(result, console, team=True)
    table = Table(title="container contract", title_justify="left")
    table.add_column("check")
    table.add_column("")
    table.add_column("detail")
    checks = contract_checks(result)
    for c in checks:
        mark = "[dim]—[/]" if c.ok is None else "[green]pass[/]" if c.ok else "[bold red]FAIL[/]"
        table.add_row(c.name, mark, c.detail)
    console.print(table)
    console.print(verdict(result, checks), highlight=False)
    console.print(where_line(result), highlight=False)
    if result.status.failure_kind == "infra":
        raise typer.Exit(ExitCode.INFRA)
    raise typer.Exit(ExitCode.OK if all(c.ok is not False for c in checks)
                     else ExitCode.AGENT)


@app.command()
def replay(
    episode: Annotated[Path, typer.Argument(help="An episode folder or its episode.mcap.")],
    verify: Annotated[bool, typer.Option(help="Check every recorded state bit for bit.")] = True,
) -> None:
    """Re-simulate an episode from its MCAP log and check it matches the live run."""
    from orchestrator._episode.replay import replay as do_replay

    path = episode_log(episode)
    with notes.status(f"replaying {path}…"):
        report = do_replay(path)
    console.print(f"{report.track} episode {report.episode}: {report.steps} steps replayed, "
                  f"{report.hashes_checked} state hashes and {report.states_checked} full "
                  "states checked")
    for m in report.mismatches:
        console.print(f"[bold red]mismatch[/]: {m}")
    if verify and not report.ok:
        console.print("[bold red]the replay does not match the log[/]")
        raise typer.Exit(ExitCode.ERROR)
    console.print("[green]the replay matches the log bit for bit[/]")


@app.command()
def preview(
    seed: Annotated[int, typer.Option(help="Scenario seed (a public one).", **SEED_RANGE)] = 0,
    split: Annotated[str, typer.Option(help="A split of the track.")] = "standard",
    track: Annotated[str, typer.Option(help="The track.")] = "track1",
    out: Annotated[Path, typer.Option(help="Folder for the PNG.")] = PREVIEWS,
) -> None:
    """A scenario preview as PNG (<track>-<split>-seed<N>.png), in runs/previews/ unless
    --out says where.

    Track 1: the top-down map with the task, beside the robot's first camera frame.
    """
    import shutil
    import tempfile

    from plugins import PluginError

    plugin = check_track(track)
    check_split(plugin, split)
    out.mkdir(parents=True, exist_ok=True)
    # Each track names its own file: drawn apart, then named by the one scheme.
    drawing = Path(tempfile.mkdtemp(prefix=".preview-", dir=out))
    try:
        drawn = plugin.preview(seed=seed, split=split, out=drawing)
        path = drawn.replace(out / preview_name(track, split, seed))
    except PluginError as e:  # the track draws none
        raise UsageError(str(e)) from None
    finally:
        shutil.rmtree(drawing, ignore_errors=True)
    console.print(f"[green]✓[/] {path}", highlight=False)


@app.command()
def picture(
    episode: Annotated[Path, typer.Argument(help="An episode folder (runs/<episode>).")],
    out: Annotated[Path | None, typer.Option(
        help="Where to write the PNG (default: the episode's host/ folder).")] = None,
) -> None:
    """Draw an episode as PNG (in its host/ folder unless --out says where).

    Track 1: the trajectory over the map; Track 2: the attempt beside the demonstration.
    """
    from plugins import PluginError
    from schemas import EpisodeResult, load_json

    folder = episode_folder(episode)
    result = load_json(folder / "host" / "result.json", EpisodeResult)
    plugin = check_track(result.track)
    try:
        path = plugin.picture(folder, out)
    except PluginError as e:  # the track draws none
        raise UsageError(str(e)) from None
    except (ValueError, KeyError) as e:  # not one of this track's episodes, a damaged log
        raise UsageError(f"{folder}: cannot draw this episode: {e}") from None
    console.print(f"[green]✓[/] {path}", highlight=False)


@images_app.command("build")
def images_build(force: Annotated[bool, typer.Option(help="Rebuild everything.")] = False) -> None:
    """Build eagc/base, eagc/agent-base and the example agents, with no registry."""
    from orchestrator._images.build import build_all

    for tag in build_all(say=lambda m: console.print(m), force=force):
        console.print(f"[green]✓[/] {tag}")


@app.command()
def cleanup(
    campaign: Annotated[str | None, typer.Option(
        help="Remove every agent of this campaign (stop its driver first).")] = None,
    runs: Annotated[Path | None, typer.Option(
        help="Also tidy killed attempts' folders under this runs or campaign folder.")] = None,
    dry_run: Annotated[bool, typer.Option(help="Only say what would be removed.")] = False,
    keep_logs: Annotated[bool, typer.Option(
        help="Keep a killed attempt's host/ folder (its partial MCAP log).")] = False,
) -> None:
    """Remove what dead episodes left: agents whose episode's heartbeat went stale (never a
    running episode's), or all of one campaign's; with --runs, killed attempts' folders."""
    from orchestrator._runtimes.cleanup import cleanup as do_cleanup

    plan = do_cleanup(campaign=campaign, runs=runs, dry_run=dry_run, keep_logs=keep_logs)
    verb = "would remove" if dry_run else "removed"
    for what, items in (("container(s)", plan.containers), ("local agent(s)", plan.local_agents),
                        ("killed attempt folder(s)", plan.folders),
                        ("output mount(s)", plan.mounts)):
        console.print(f"{verb} {len(items)} {what}", highlight=False)
        for item in items:
            console.print(f"  {item}", highlight=False, soft_wrap=True)
    if plan.kept_live:
        console.print(f"left {plan.kept_live} agent(s) of live episodes alone")
    for note in plan.notes:
        console.print(f"[yellow]{note}[/]", highlight=False)


@app.command()
def tracks() -> None:
    """List the installed tracks."""
    from plugins import PluginError, available_tracks, load_track

    for name in available_tracks():
        try:
            plugin = load_track(name)
        except PluginError as e:
            console.print(f"[bold red]{name}[/]: cannot be loaded: {e}")
            continue
        stages = ", ".join(f"{s.name} {s.budget_s:g}s" for s in plugin.stages())
        console.print(f"[bold]{name}[/]: {plugin.title}\n  stages: {stages}\n"
                      f"  splits: {', '.join(plugin.split_names())}")


def _one_line_summaries(typer_app: typer.Typer) -> None:
    """Each command's summary in ``eagc --help``: the first paragraph of its docstring on
    one line (the listing kept the docstring's line breaks mid-sentence)."""
    for info in typer_app.registered_commands:
        doc = info.help or (info.callback.__doc__ if info.callback else None)
        if info.short_help is None and doc:
            info.short_help = " ".join(doc.strip().split("\n\n")[0].split())
    for group in typer_app.registered_groups:
        if group.typer_instance is not None:
            _one_line_summaries(group.typer_instance)


_one_line_summaries(app)


def main() -> None:
    # Sim hosts render headless (EGL on Mesa); must be set before mujoco is first imported.
    os.environ.setdefault("MUJOCO_GL", "egl")
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    app()


if __name__ == "__main__":
    main()
