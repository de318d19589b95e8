"""One-screen score cards and failure reports (rich).

Two audiences. The organizer's card (``eagc run-episode``) shows everything the episode
recorded: score components with this episode's weights and the scorer's notes. The team's
card (``eagc test``, and the per-team report of a campaign) is neutral about the hidden
scenario: no components, weights or notes (a redistributed weight or a note such as "no
exception in this episode" says what the scenario held), only what the agent did, how it
ended and what was wrong with its files.
"""

from __future__ import annotations

from rich.console import Console, Group, RenderableType
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from schemas import IGNORED, EpisodeResult, reason_lines


def _mib(n: int | None) -> str:
    return "—" if n is None else f"{n / 2**20:.0f} MiB"


def number(v: float) -> str:
    """A number as read: weights exactly (``0.125``), small values with two significant
    digits (``0.37``), others with one decimal at most."""
    if v == 0 or abs(v) >= 100:
        return f"{v:.0f}" if float(v).is_integer() else f"{v:.1f}"
    if abs(v) < 1:
        return f"{v:.2g}"
    return f"{v:.1f}"


def weight(w: float) -> str:
    """A weight exactly as the track set it (``0.125``, ``0.25``), never rounded to 2 places."""
    return f"{w:.6g}"


def latency(ms: float) -> str:
    """Milliseconds: ``0.37`` below 1 ms, one decimal above."""
    return f"{ms:.2g}" if ms < 1 else f"{ms:.1f}"


def render(result: EpisodeResult, *, team: bool = False) -> Panel:
    """The score card, with the failure report when the episode failed.

    ``team``: the team's neutral view (module docstring).
    """
    card = result.score
    ok = result.failure is None
    title = (f"[bold]{result.track}[/] · split {result.split} · episode {result.episode} · "
             f"{result.runtime}")
    parts: list[RenderableType] = []

    summary = Table.grid(padding=(0, 2))
    summary.add_row("status", Text(result.status.value, style="green" if ok else "bold red"))
    summary.add_row("score", Text(f"{100 * card.total:.1f} / 100", style="bold"))
    summary.add_row("stages", " → ".join(result.stages_reached) or "none")
    s = result.stats
    lat = "—" if s.latency_ms_median is None else (
        f"{latency(s.latency_ms_median)} ms median, {latency(s.latency_ms_p99 or 0.0)} ms p99")
    summary.add_row("steps", f"{s.steps}  (invalid actions {s.invalid_actions}, "
                             f"protocol errors {sum(s.protocol_errors.values())})")
    summary.add_row("agent latency", lat)
    summary.add_row("peak memory", _mib(s.peak_memory_bytes))
    summary.add_row("wall time", f"{s.wall_s:.1f} s")
    parts.append(summary)

    if not team:
        comp = Table(title="score components", title_justify="left", expand=False)
        comp.add_column("component")
        comp.add_column("weight", justify="right")
        comp.add_column("value", justify="right")
        comp.add_column("weighted", justify="right")
        for name, value in card.components.items():
            w = card.weights.get(name)
            comp.add_row(name, "—" if w is None else weight(w), f"{value:.3f}",
                         "—" if w is None else f"{w * value:.3f}")
        parts.append(comp)

    if result.files:
        files = Table(title="files in /output", title_justify="left")
        files.add_column("file", no_wrap=True)
        files.add_column("size", justify="right")
        files.add_column("check")
        for f in result.files:
            if f.ok:
                check = Text("ok", style="green")
                for line in file_lines(f.reason):
                    check.append(f"\n{line}", style="dim")
            else:
                check = Text("\n".join(file_lines(f.reason)) or "rejected", style="red")
            files.add_row(f.name, "—" if f.size is None else str(f.size), check)
        parts.append(files)
    if not team:
        for note in card.notes:
            parts.append(Text(f"note: {note}", style="dim"))

    if result.failure is not None:
        f = result.failure
        fail = Table.grid(padding=(0, 2))
        fail.add_row("failure", Text(f"{f.kind} · {f.status.value}", style="bold red"))
        fail.add_row("stage reached", f.stage_reached or "none (before the first stage)")
        fail.add_row("limit hit", f.limit_hit or "—")
        fail.add_row("exit code", "—" if f.exit_code is None else str(f.exit_code))
        fail.add_row("OOM-killed", "yes" if f.oom_killed else "no")
        fail.add_row("what happened", f.message)
        parts.append(Panel(fail, title="failure report", border_style="red"))
        if f.log_tail.strip():
            tail = "\n".join(f.log_tail.rstrip().splitlines()[-12:])
            parts.append(Panel(Text(tail), title="last lines the agent printed",
                               border_style="dim"))
    return Panel(Group(*parts), title=title, border_style="green" if ok else "red")


def file_lines(reason: str) -> list[str]:
    """What was wrong with a file (or, for a file that passed, the keys nothing grades),
    one line per field path and problem, as ``schemas._io.problem_lines`` wrote them
    (the keys nothing grades first): the same lines in every report (score card,
    failure report, ``eagc test``, ``--team``, ``eagc check-files``)."""
    lines = reason_lines(reason)
    return ([x for x in lines if x.startswith(f"{IGNORED}: ")]
            + [x for x in lines if not x.startswith(f"{IGNORED}: ")])


def file_problem(reason: str) -> str:
    """A rejected file's first problem, with its field path, in one line."""
    lines = reason_lines(reason)
    return lines[0] if lines else "rejected"


def where_line(result: EpisodeResult) -> str:
    """Where an episode's files are, in one line."""
    if not result.episode_dir:
        return "nothing was kept on disk"
    return (f"episode folder: {result.episode_dir} (host/result.json, host/agent.log, "
            "host/episode.mcap, host/output/)")


def print_result(result: EpisodeResult, console: Console | None = None, *,
                 team: bool = False) -> None:
    (console or Console()).print(render(result, team=team))
