"""``eagc report CAMPAIGN.yaml | RUNS_DIR | EPISODE_DIR --out DIR``: the results as static
web pages.

Mount with ``app.command("report", epilog=REPORT_CODES)(report_cmd)``. Writes the episode
viewer's site (``orchestrator._viewer``; docs/viewer.md): for a campaign an index (the
leaderboard), a page per team and a page per episode; for a folder of ``run-episode``
results (no campaign) the team's page of those episodes as ``DIR/index.html`` and a page
per episode; for one episode folder its page as ``DIR/index.html``. ``--team`` keeps one
team's pages only (its page is the index); ``--organizer`` adds the hidden scenario, which
a team must never be sent.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from orchestrator.cli.common import ExitCode

REPORT_CODES = ("Exit codes: 0 the pages were written; 1 an error, on one line (no "
                "results yet); 2 usage error (no such file, folder or team, no episode in "
                "the folder).")

out = Console(highlight=False, soft_wrap=True, markup=False)
notes = Console(stderr=True, highlight=False)


def report_cmd(
    source: Annotated[Path, typer.Argument(
        help="A campaign file (YAML), a folder of run-episode results (runs/) or one "
             "episode folder (runs/<episode>).")],
    out_dir: Annotated[Path, typer.Option("--out", help="Folder for the pages.")],
    team: Annotated[str | None, typer.Option(
        help="Only this team's pages (a campaign): what the team may be sent.")] = None,
    organizer: Annotated[bool, typer.Option(
        "--organizer", help="Add the hidden scenario (ground truth, seed): organizers "
                            "only.")] = False,
) -> None:
    """Write the results as static web pages that open from disk: the leaderboard, each
    team's episodes, and each episode's timeline, camera frames, map, files and score.
    A folder of run-episode results gets the page of its episodes, without a campaign."""
    from orchestrator._errors import UsageError
    from orchestrator._viewer import write_campaign_site, write_episode_site, write_runs_site

    if not source.exists():
        raise UsageError(f"{source} does not exist")
    if source.is_dir():
        if team is not None:
            raise UsageError("--team is for a campaign, not a folder of episodes")
        if (source / "host" / "result.json").is_file():
            pages = write_episode_site(source, out_dir, organizer=organizer)
        else:
            with notes.status("writing pages…") as status:
                pages = write_runs_site(source, out_dir, organizer=organizer,
                                        say=lambda m: status.update(f"writing {m}"))
    else:
        from orchestrator._campaign.spec import load_campaign, store_path
        from orchestrator._results.store import ResultsStore

        spec = load_campaign(source)
        path = store_path(spec)
        if not path.exists():
            notes.print(f"no results yet: {path} does not exist (run the campaign first)")
            raise typer.Exit(ExitCode.ERROR)
        with ResultsStore(path) as store, notes.status("writing pages…") as status:
            pages = write_campaign_site(spec, store, out_dir, team=team, organizer=organizer,
                                        say=lambda m: status.update(f"writing {m}"))
    index = out_dir / "index.html"
    out.print(f"{len(pages)} page{'s' if len(pages) != 1 else ''} written; open in a "
              "browser:")
    out.print(f"  {index}")
    if organizer:
        notes.print("organizer's view: it holds the hidden scenario; never send it to a team")
