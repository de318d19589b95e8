"""The frozen final's commands (``docs/channel.md``, The frozen final): ``eagc challenge
freeze``, ``eagc challenge manifest`` and ``eagc challenge verify``. Registered on the
``challenge`` group at the end of ``orchestrator/cli/channel.py``."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

out = Console()

DataOpt = Annotated[Path, typer.Option("--data", help="The channel's data folder.")]
DEFAULT_DATA = Path("channel")
PhaseOpt = Annotated[str | None, typer.Option(
    "--phase", help="The final phase (default: the challenge's phase of kind 'final').")]


def _who() -> str:
    import getpass

    return os.environ.get("EAGC_ORGANIZER") or getpass.getuser()


def freeze_cmd(
    team: Annotated[str, typer.Argument(help="The finalist.")],
    submission: Annotated[str, typer.Argument(help="Its submission to freeze (queued, "
                                              "running or scored).")],
    report: Annotated[Path, typer.Option("--report", help="The technical report (PDF or "
                                         "Markdown).")],
    statement: Annotated[Path | None, typer.Option(
        "--statement", help="The optional open-source statement (YAML or JSON).")] = None,
    phase: PhaseOpt = None,
    data: DataOpt = DEFAULT_DATA,
) -> None:
    """Freeze a finalist's submission, report and statement before the final's deadline."""
    from orchestrator._channel.final import freeze
    from orchestrator._channel.serve import open_channel

    got = freeze(open_channel(data), team, submission, report, statement, phase=phase,
                 who=_who())
    out.print(f"froze {got.submission} for {team} in the final {got.phase}: "
              f"{got.repository}@{got.digest} (image {got.image_id[:19]})", highlight=False)
    for kind, entry in got.files.items():
        out.print(f"  {kind:<10} {entry['name']}  sha256 {entry['sha256'][:16]}…",
                  highlight=False)


def manifest_cmd(
    phase: Annotated[str, typer.Argument(help="The final phase.")],
    data: DataOpt = DEFAULT_DATA,
    out_dir: Annotated[Path | None, typer.Option(
        "--out", help="Where to write it (default: <data>/final).")] = None,
) -> None:
    """After the deadline: the signed manifest of the frozen final and its campaign."""
    from orchestrator._channel.final import write_manifest
    from orchestrator._channel.serve import open_channel

    w = write_manifest(open_channel(data), phase, out_dir)
    for path, what in ((w.manifest, "the manifest"), (w.signature, "its Ed25519 signature"),
                       (w.public_key, "the public key (publish it)"),
                       (w.campaign, "the final's campaign (eagc campaign run)")):
        out.print(f"  {path}  {what}", highlight=False)


def verify_cmd(
    manifest: Annotated[Path, typer.Argument(help="manifest.json (manifest.sig beside it).")],
    runs: Annotated[Path | None, typer.Option(
        "--runs", help="A campaign's output folder (its results.sqlite): check it ran "
        "exactly the manifest's images.")] = None,
    files: Annotated[Path | None, typer.Option(
        "--files", help="Where the frozen files are (default: the manifest's folder).")
                     ] = None,
    key: Annotated[Path | None, typer.Option(
        "--key", help="The public key (PEM; default: manifest.pub beside the manifest, "
        "else <data>/keys/manifest.pub).")] = None,
    data: Annotated[Path | None, typer.Option("--data", help="The channel's data folder "
                                              "(for its public key).")] = None,
) -> None:
    """Check a manifest's signature, its files and, with --runs, the campaign's images."""
    from orchestrator._channel.final import verify

    for check in verify(manifest, key=key, files=files, runs=runs, data=data):
        out.print(f"{'ok  ' if check.ok else 'FAIL'}  {check.name}: {check.detail}",
                  highlight=False, soft_wrap=True)
        if not check.ok:
            raise typer.Exit(1)
    out.print("the manifest holds", highlight=False)
