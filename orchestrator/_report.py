"""One-screen score cards and failure reports (rich)."""

from __future__ import annotations

from rich.console import Console, Group
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from schemas import EpisodeResult


def _mib(n: int | None) -> str:
    return "—" if n is None else f"{n / 2**20:.0f} MiB"


def render(result: EpisodeResult) -> Panel:
    """The score card, with the failure report when the episode failed."""
    card = result.score
    ok = result.failure is None
    title = (f"[bold]{result.track}[/] · split {result.split} · episode {result.episode} · "
             f"{result.runtime}")
    parts: list = []

    summary = Table.grid(padding=(0, 2))
    summary.add_row("status", Text(result.status.value, style="green" if ok else "bold red"))
    summary.add_row("score", Text(f"{100 * card.total:.1f} / 100", style="bold"))
    summary.add_row("stages", " → ".join(result.stages_reached) or "none")
    s = result.stats
    lat = "—" if s.latency_ms_median is None else (
        f"{s.latency_ms_median:.1f} ms median, {s.latency_ms_p99:.1f} ms p99")
    summary.add_row("steps", f"{s.steps}  (invalid actions {s.invalid_actions}, "
                             f"protocol errors {sum(s.protocol_errors.values())})")
    summary.add_row("agent latency", lat)
    summary.add_row("peak memory", _mib(s.peak_memory_bytes))
    summary.add_row("wall time", f"{s.wall_s:.1f} s")
    parts.append(summary)

    comp = Table(title="score components", title_justify="left", expand=False)
    comp.add_column("component")
    comp.add_column("weight", justify="right")
    comp.add_column("value", justify="right")
    comp.add_column("weighted", justify="right")
    for name, value in card.components.items():
        w = card.weights.get(name)
        comp.add_row(name, "—" if w is None else f"{w:.2f}", f"{value:.3f}",
                     "—" if w is None else f"{w * value:.3f}")
    parts.append(comp)

    if result.files:
        files = Table(title="files in /output", title_justify="left")
        files.add_column("file")
        files.add_column("size", justify="right")
        files.add_column("check")
        for f in result.files:
            check = (Text("ok", style="green") if f.ok
                     else Text(f.reason.splitlines()[0][:90], style="red"))
            files.add_row(f.name, "—" if f.size is None else str(f.size), check)
        parts.append(files)
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
    if result.episode_dir:
        parts.append(Text(f"organizer files: {result.episode_dir}/host", style="dim"))
    return Panel(Group(*parts), title=title, border_style="green" if ok else "red")


def print_result(result: EpisodeResult, console: Console | None = None) -> None:
    (console or Console()).print(render(result))
