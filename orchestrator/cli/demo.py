"""``eagc demo``: the demo campaigns of ``examples/campaigns/demo_<track>.yaml``.

Each file is an ordinary local campaign: fixed name, fixed episode counts, no secret (so
its seeds derive from the name: the same every run), every baseline of the track as a
submission, step caps that bind long before the scaled wall-clock budgets (so that
outcomes do not depend on how busy the machine is). Adding a baseline to the demo is
adding its image to the file. The demo runs each file whose track is installed, on an
embedded Ray, then prints its leaderboard and where the results are.

Results go where the file says (``runs/demo``): a second ``eagc demo`` finds them in the
store and runs nothing again; ``eagc leaderboard``/``eagc status`` on the file show them.
With ``--output DIR``, or without a Docker engine (the agents then run as local processes,
as campaign ``<name>-local``, so that their results never pass for the sandbox's), the
campaign actually run differs from the file: the demo writes it beside its results
(``DIR/demo_<track>.yaml``, ``demo_<track>_local.yaml``) and names that file instead. Seeds
derive from the campaign's name, so a local demo plays other episodes than a Docker demo,
and its scores and ranks differ: the demo says so (``LOCAL_NOTE``).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from rich.console import Console

from orchestrator._errors import UsageError

REPO = Path(__file__).resolve().parents[2]
DEMOS = REPO / "examples" / "campaigns"
#: What the demo says when its agents run as local processes.
LOCAL_NOTE = ("The example agents run as local processes (no sandbox), as campaigns "
              "<demo>-local beside the Docker demo's. Seeds derive from a campaign's name, "
              "so these episodes, scores and ranks differ from a Docker run's.")


def demo_files(tracks: list[str] | None = None) -> dict[str, Path]:
    """``track → examples/campaigns/demo_<track>.yaml`` for the installed tracks (or the
    ``tracks`` asked for; UsageError naming one without a demo file)."""
    from plugins import available_tracks

    installed = available_tracks()
    found = {t: DEMOS / f"demo_{t}.yaml" for t in installed
             if (DEMOS / f"demo_{t}.yaml").is_file()}
    if tracks is None:
        return found
    missing = [t for t in tracks if t not in found]
    if missing:
        from orchestrator.cli.common import _suggest

        raise UsageError(f"no demo for track {missing[0]!r}.{_suggest(missing[0], list(found))}"
                         f" The demos are "
                         f"{', '.join(found) or 'none'} (examples/campaigns/demo_<track>.yaml)")
    return {t: found[t] for t in tracks}


def _load(path: Path, output: Path | None) -> Any:
    """The demo file's campaign, checked with ``output`` in place of the file's own
    (a file whose folder would be too long for the sockets is fine with a short one)."""
    import json

    import yaml

    from orchestrator._campaign.spec import check_campaign, load_campaign, resolved
    from schemas import CampaignSpec, SchemaError, parse_json

    if output is None:
        try:
            return load_campaign(path)
        except SchemaError as e:
            if any(p.startswith("output:") for p in e.problems):
                raise UsageError(f"{e.summary}: give one with `eagc demo --output DIR`"
                                 ) from None
            raise
    try:
        doc = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as e:
        raise SchemaError(str(path), [f"cannot read the demo file: {e}"]) from None
    spec = resolved(parse_json(json.dumps(doc, default=str), CampaignSpec, source=str(path)),
                    path.parent)
    spec = spec.model_copy(update={"output": output})
    check_campaign(spec, source=str(path))
    return spec


def _write_spec(spec: Any, path: Path) -> None:
    import yaml

    path.parent.mkdir(parents=True, exist_ok=True)
    doc = spec.model_copy(update={"output": spec.output.resolve()}).model_dump(
        mode="json", exclude_defaults=True)
    path.write_text("# The campaign `eagc demo` ran (written by it).\n"
                    + yaml.safe_dump(doc, sort_keys=False))


def _as_local(spec: Any) -> Any:
    """The same campaign with the example agents as local processes (no sandbox)."""
    from orchestrator._images.build import example_agents

    folders = example_agents()
    python = sys.executable or "python3"
    subs = tuple(s.model_copy(update={"image": f"{python} {folders[s.image] / 'agent.py'}"})
                 for s in spec.submissions if s.image in folders)
    return spec.model_copy(update={"name": f"{spec.name}-local", "runtime": "local",
                                   "submissions": subs})


def _with_images(spec: Any, console: Console) -> Any:
    """Builds the example images the campaign names (offline); drops, saying so, a
    submission whose image does not build or is neither an example nor loaded here."""
    from orchestrator._images.build import (
        ImageBuildError,
        build_agent_base,
        build_folder,
        example_agents,
    )
    from orchestrator._runtimes.docker import docker_client

    client = docker_client()
    folders = example_agents()
    say = lambda m: console.print(f"[dim]{m}[/]", highlight=False)  # noqa: E731
    keep = []
    with console.status("building images offline (first time: a few minutes)…"):
        build_agent_base(client, say)
        for sub in spec.submissions:
            try:
                if sub.image in folders:
                    build_folder(client, folders[sub.image], sub.image, say)
                else:
                    client.images.get(sub.image)
            except ImageBuildError as e:
                console.print(f"[yellow]leaving {sub.team} out: {sub.image} does not build "
                              f"({e})[/]", highlight=False)
                continue
            except Exception:  # noqa: BLE001 - docker.errors.ImageNotFound and kin
                console.print(f"[yellow]leaving {sub.team} out: {sub.image} is not an "
                              "example agent and is not loaded here[/]", highlight=False)
                continue
            keep.append(sub)
    if not keep:
        raise UsageError(f"{spec.name}: none of its images can be built or found here")
    return spec.model_copy(update={"submissions": tuple(keep)})


def run_demo(*, runtime: str = "auto", tracks: list[str] | None = None,
             workers: int | None = None, output: Path | None = None,
             console: Console | None = None) -> int:
    """Runs the demo campaigns; returns the exit code (0, 3 when episodes are quarantined,
    130 when cancelled). ``console``: progress and notes; leaderboards go to stdout."""
    import os

    from orchestrator._campaign.driver import run_campaign
    from orchestrator._campaign.driver_io import CampaignOptions
    from orchestrator.cli.campaign import _print_leaderboard, where_results
    from orchestrator.cli.common import ExitCode

    console = console or Console(stderr=True)
    files = demo_files(tracks)
    if not files:
        raise UsageError(f"no demo campaign files in {DEMOS} for the installed tracks")
    if runtime == "auto":
        from orchestrator._runtimes.engine import docker_answers

        runtime = "docker" if docker_answers() else "local"
        if runtime == "local":
            console.print("[yellow]No Docker engine answers.[/]")
    if runtime == "local":
        console.print(f"[yellow]{LOCAL_NOTE}[/]", highlight=False)
    workers = workers or max(1, min(2, os.cpu_count() or 1))
    code = ExitCode.OK
    for track, path in files.items():
        spec = _load(path, output)
        source = path
        if runtime == "local":
            spec = _as_local(spec)
        else:
            spec = _with_images(spec, console)
        if output is not None or runtime == "local":
            source = spec.output.resolve() / f"{spec.name.replace('-', '_')}.yaml"
            _write_spec(spec, source)
        eps = sum(s.episodes for s in spec.splits)
        console.print(f"[bold]{spec.name}[/] ({track}): {len(spec.submissions)} agent(s) × "
                      f"{eps} episodes, {workers} worker(s), runtime {runtime}",
                      highlight=False)
        report = run_campaign(spec, CampaignOptions(workers=workers), console=console)
        if report.skipped:
            console.print(f"{report.skipped} episode(s) were already in the store: shown, "
                          "not run again (a new --output runs them afresh)", highlight=False)
        _print_leaderboard(spec)
        print(flush=True)
        for line in where_results(spec, _shown(source)):
            console.print(line, highlight=False, soft_wrap=True)
        console.print()
        if report.cancelled:
            return ExitCode.CANCELLED
        if report.quarantined:
            code = ExitCode.INFRA
    return code


def _shown(path: Path) -> Path:
    """``path`` relative to the working directory when it is below it (shorter to type)."""
    try:
        return path.resolve().relative_to(Path.cwd())
    except ValueError:
        return path
