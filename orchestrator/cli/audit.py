"""``eagc audit CAMPAIGN.yaml --team NAME [--rerun K]``: the organizers' audit of a team.

Mount with ``app.command("audit", epilog=AUDIT_CODES)(audit_cmd)``. Each team's report
(text and JSON, organizer-only) goes to ``<output>/<campaign>/audit/<team>.txt|.json``;
the text is printed too. docs/audit.md says what the checks mean.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from orchestrator.cli.common import ExitCode

AUDIT_CODES = ("Exit codes: 0 every report written and clean (every replay matches its "
               "log, no check raised a flag); 1 a flag, a replay that does not match, or "
               "an error, on one line; 2 usage error (no such team, no results yet, a bad "
               "--rerun).")

out = Console(highlight=False, soft_wrap=True, markup=False)
notes = Console(stderr=True, highlight=False)


def audit_cmd(
    campaign: Annotated[Path, typer.Argument(help="The campaign file (YAML).")],
    team: Annotated[list[str], typer.Option(
        help="The team to audit (repeat for several).")],
    rerun: Annotated[int, typer.Option(
        min=0, help="Run this many of each team's episodes again (same image and seed).")
                     ] = 0,
    output: Annotated[Path | None, typer.Option(
        help="Folder for the reports (default: <output>/<campaign>/audit).")] = None,
) -> None:
    """Audit teams of a campaign: replay --verify every episode, rerun some, and check the
    agent's files against what it was shown (organizers only; see docs/audit.md)."""
    from orchestrator._campaign.audit import (
        audit_folder,
        audit_team,
        report_lines,
        team_episodes,
        write_report,
    )
    from orchestrator._campaign.spec import load_campaign

    spec = load_campaign(campaign)
    for name in team:  # every name checked before any work
        team_episodes(spec, name)
    folder = output or audit_folder(spec)
    clean = True
    for name in team:
        with notes.status(f"auditing {name}…") as status:
            audit = audit_team(spec, name, rerun=rerun,
                               say=lambda m: status.update(m))
        text, data = write_report(audit, folder)
        out.print("\n".join(report_lines(audit)))
        out.print(f"report: {text}\n        {data}\n")
        clean = clean and audit.clean
    raise typer.Exit(ExitCode.OK if clean else ExitCode.ERROR)
