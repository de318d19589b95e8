"""Writes the static site: an index, a page per team and a page per episode.

    <out>/index.html             the leaderboard (or, with a team, that team's page; for
                                 a folder of ``run-episode`` results, its episodes); for
                                 organizers, each team's resource disclosure too
    <out>/teams/<team>.html      a team's episodes, each linked
    <out>/episodes/<id>.html     one episode (``write_episode_site``: <out>/index.html)

Pages are self-contained: styles, script and pictures (``data:`` URIs) are inside them,
nothing is fetched, so they open from disk. The templates are Jinja2 (package data under
``templates/``), autoescaped.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from orchestrator._errors import UsageError
from orchestrator._results.leaderboard import CI_KEY, LEGEND, Leaderboard
from orchestrator._viewer.episode import EpisodeView, read_episode
from plugins import Column
from schemas import CampaignSpec, EpisodeResult


def _env() -> Any:
    from jinja2 import Environment, PackageLoader, StrictUndefined, select_autoescape

    env = Environment(loader=PackageLoader("orchestrator._viewer", "templates"),
                      autoescape=select_autoescape(["html"]), undefined=StrictUndefined,
                      trim_blocks=True, lstrip_blocks=True)
    env.filters["pct"] = lambda v: "—" if v is None else f"{100 * v:.1f}"
    env.filters["num"] = lambda v: "—" if v is None else f"{v:.3g}"
    return env


def slug(name: str) -> str:
    """A file name for a team: its name with anything but ``[A-Za-z0-9._-]`` as ``_``."""
    return re.sub(r"[^A-Za-z0-9._-]", "_", name) or "_"


def _write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


def episode_page(view: EpisodeView, *, back: str | None, back_text: str) -> str:
    """The HTML of one episode's page."""
    data = {"last_step": view.last_step, "stages": view.stages, "frames": view.frames,
            "path": view.path, "map": view.map_frame, "pictures": view.pictures}
    return _env().get_template("episode.html").render(
        v=view, r=view.result, data=data, back=back, back_text=back_text)


def write_episode_site(folder: Path, out: Path, *, organizer: bool = False,
                       public_seed: bool = True) -> list[Path]:
    """One episode's page as ``out/index.html`` (by default an episode of a public seed:
    ``eagc run-episode``'s, a public split's); returns the pages written."""
    view = read_episode(folder, organizer=organizer, public_seed=public_seed)
    return [_write(out / "index.html", episode_page(view, back=None, back_text=""))]


def episode_folders(folder: Path) -> list[Path]:
    """The episode folders under ``folder`` (``<episode>/host/result.json`` at any depth,
    as ``eagc run-episode --runs-dir`` leaves them), by path."""
    return sorted(p.parent.parent for p in folder.rglob("host/result.json")
                  if p.is_file())


def write_runs_site(folder: Path, out: Path, *, organizer: bool = False,
                    say: Callable[[str], None] = lambda _m: None) -> list[Path]:
    """The pages of the ``run-episode`` results under ``folder`` without a campaign: the
    team's page as ``out/index.html`` (its episodes by track, each split's mean score)
    and a page per episode. Their seeds are public: the team chose them. Returns the
    pages written; UsageError when ``folder`` holds no episode folder."""
    found = episode_folders(folder)
    if not found:
        raise UsageError(f"{folder} is not an episode folder and holds none (an episode "
                         "folder has host/result.json; run-episode writes them under "
                         "--runs-dir)")
    written: list[Path] = []
    views: list[EpisodeView] = []
    for path in found:
        say(path.name)
        view = read_episode(path, organizer=organizer, public_seed=True)
        written.append(_write(out / "episodes" / f"{view.id}.html", episode_page(
            view, back="../index.html", back_text=f"the episodes in {folder.name}")))
        views.append(view)
    tracks = []
    for track in sorted({v.result.track for v in views}):
        mine = sorted((v for v in views if v.result.track == track),
                      key=lambda v: (v.result.split, v.result.started_at))
        components: list[str] = []
        for v in mine:
            components += [c for c in v.result.score.components if c not in components]
        tracks.append({"name": track, "splits": _split_rows(mine),
                       "components": components,
                       "episodes": [_run_row(v) for v in mine]})
    html = _env().get_template("runs.html").render(
        folder=folder.name or str(folder), tracks=tracks, total=len(views),
        organizer=organizer)
    written.append(_write(out / "index.html", html))
    return written


def _run_row(view: EpisodeView) -> dict[str, Any]:
    r = view.result
    return {"id": view.id, "page": f"episodes/{view.id}.html", "split": r.split,
            "seed": view.seed, "image": r.image, "status": r.status.value,
            "stage": (r.stages_reached or ["none"])[-1], "score": r.score.total,
            "components": r.score.components}


def _split_rows(views: list[EpisodeView]) -> list[dict[str, Any]]:
    rows = []
    for split in dict.fromkeys(v.result.split for v in views):
        scores = [v.result.score.total for v in views if v.result.split == split]
        done = sum(v.result.failure is None for v in views if v.result.split == split)
        rows.append({"split": split, "episodes": len(scores), "completed": done,
                     "mean": sum(scores) / len(scores)})
    return rows


def _columns(board: Leaderboard) -> list[Column]:
    at = next(i for i, c in enumerate(board.columns) if c.key == "final")
    return [*board.columns[: at + 1], Column(CI_KEY, "95% CI"), *board.columns[at + 1:]]


def _episode_row(result: EpisodeResult, index: int, page: str | None) -> dict[str, Any]:
    return {"split": result.split, "index": index, "status": result.status.value,
            "score": result.score.total, "components": result.score.components,
            "page": page, "stage": (result.stages_reached or ["none"])[-1]}


#: The columns of the organizer's disclosure table, as ``summary_lines`` labels them.
DISCLOSURE_COLUMNS = ("data", "pretrained models", "compute", "dependencies", "open source")


def disclosure_rows(spec: CampaignSpec) -> list[dict[str, Any]]:
    """Each team's resource disclosure as the campaign keeps it, for the organizer's
    index: its status (``ok``, ``missing``, ``invalid``), the file, and one cell per
    ``DISCLOSURE_COLUMNS`` (or the problems)."""
    from orchestrator._campaign.disclosure import kept_disclosures, summary_lines
    from orchestrator._campaign.spec import campaign_dir

    rows = []
    for team, kept in kept_disclosures(spec, campaign_dir(spec)).items():
        parts = dict(line.split(": ", 1) for line in summary_lines(kept))
        rows.append({"team": team, "status": kept.status, "file": parts.get("file", ""),
                     "cells": [parts.get(c, "") for c in DISCLOSURE_COLUMNS],
                     "problems": list(kept.problems)})
    return rows


def write_campaign_site(spec: CampaignSpec, store: Any, out: Path, *, team: str | None = None,
                        organizer: bool = False,
                        say: Callable[[str], None] = lambda _m: None) -> list[Path]:
    """The site of a campaign from ``store`` (a ResultsStore); only ``team``'s pages when
    given (its page is then the index). Returns the pages written."""
    from orchestrator._results.leaderboard import build_leaderboard

    board = build_leaderboard(spec, store)
    teams = [r.team for r in board.rows]
    if team is not None and team not in teams:
        import difflib

        hint = difflib.get_close_matches(team, teams, n=1, cutoff=0.5)
        did = f" Did you mean {hint[0]!r}?" if hint else ""
        raise UsageError(f"campaign {spec.name!r} has no team {team!r}.{did}")
    env = _env()
    stored = store.results(spec.name)
    held = store.quarantined(spec.name)
    order = {s.name: i for i, s in enumerate(spec.splits)}
    written: list[Path] = []
    cols = _columns(board)
    for row in board.rows:
        if team is not None and row.team != team:
            continue
        mine = sorted((e for e in stored if e.key.submission == row.team),
                      key=lambda e: (order.get(e.key.split, 99), e.key.index))
        episodes = []
        components: list[str] = []
        for e in mine:
            page = None
            folder = Path(e.result.episode_dir) if e.result.episode_dir else None
            if folder is not None and (folder / "host" / "result.json").is_file():
                say(f"{row.team}: {e.key.split}/{e.key.index}")
                # A local campaign's seeds derive from its name: public. Others: hidden.
                view = read_episode(folder, organizer=organizer,
                                    public_seed=spec.phase == "local")
                up = "../index.html" if team is not None else f"../teams/{slug(row.team)}.html"
                written.append(_write(out / "episodes" / f"{view.id}.html", episode_page(
                    view, back=up, back_text=f"{row.team} in {spec.name}")))
                page = f"episodes/{view.id}.html"
            episodes.append(_episode_row(e.result, e.key.index, page))
            components += [c for c in e.result.score.components if c not in components]
        quarantined = [{"split": q.key.split, "index": q.key.index} for q in held
                       if q.key.submission == row.team]
        html = env.get_template("team.html").render(
            spec=spec, board=board, row=row, cells=[(c.title, board.cell(row, c))
                                                    for c in cols],
            episodes=episodes, components=components, quarantined=quarantined,
            organizer=organizer, root="" if team is not None else "../",
            back=None if team is not None else "../index.html")
        written.append(_write(out / "index.html" if team is not None
                              else out / "teams" / f"{slug(row.team)}.html", html))
    if team is None:
        rows = [{"rank": r.rank, "ranks": r.ranks, "team": r.team,
                 "page": f"teams/{slug(r.team)}.html",
                 "cells": [board.cell(r, c) for c in cols],
                 "episodes": f"{r.episodes}/{r.planned}"} for r in board.rows]
        html = env.get_template("index.html").render(
            spec=spec, board=board, titles=[c.title for c in cols], rows=rows,
            legend=LEGEND, organizer=organizer, failures=board.failures,
            disclosures=disclosure_rows(spec) if organizer else [],
            disclosure_columns=DISCLOSURE_COLUMNS)
        written.append(_write(out / "index.html", html))
    return written

