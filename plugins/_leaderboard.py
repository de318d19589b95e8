"""A track's leaderboard: its columns, and the row ``TrackPlugin.summarize`` gives by default."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from schemas import EpisodeResult


@dataclass(frozen=True)
class Column:
    """A leaderboard column: ``key`` in the row ``summarize`` returns."""

    key: str
    title: str
    fmt: str = "{:.1f}"
    lower_is_better: bool = False


#: The columns of a track that does not lay out its own table.
DEFAULT_COLUMNS = (
    Column("final", "Final"),
    Column("task_success", "Task Succ. %"),
    Column("invalid_actions", "Invalid Act/Ep", lower_is_better=True),
    Column("latency_ms", "Latency ms", "{:.0f}", lower_is_better=True),
    Column("peak_mem_gb", "Peak Mem GB", "{:.2f}", lower_is_better=True),
    Column("runtime_min", "Runtime min", "{:.1f}", lower_is_better=True),
)


def mean(values: Sequence[float]) -> float | None:
    """The mean; None for no values."""
    return sum(values) / len(values) if values else None


def resource_columns(results: Sequence[EpisodeResult]) -> dict[str, float | None]:
    """The columns every track shares: agent latency (median of the episodes' medians),
    peak memory (the largest), mean runtime, and the number of episodes."""
    lat = [r.stats.latency_ms_median for r in results if r.stats.latency_ms_median is not None]
    mem = [r.stats.peak_memory_bytes for r in results if r.stats.peak_memory_bytes]
    return {
        "latency_ms": sorted(lat)[len(lat) // 2] if lat else None,
        "peak_mem_gb": max(mem) / 2**30 if mem else None,
        "runtime_min": mean([r.stats.wall_s / 60 for r in results]),
        "episodes": float(len(results)),
    }


def mean_row(results: Sequence[EpisodeResult],
             splits: Mapping[str, tuple[float, Mapping[str, Any]]]) -> dict[str, float | None]:
    """One submission's row on a 0–100 scale (``TrackPlugin.summarize``' default): the mean
    total per split, ``final`` as the split-weighted mean (paper eq. 2; the plain mean when
    one split), score metrics averaged (``task_success`` etc. as percentages), invalid
    actions per episode, median agent latency, peak memory and runtime."""
    by_split: dict[str, list[float]] = {}
    for r in results:
        by_split.setdefault(r.split, []).append(100.0 * r.score.total)
    row: dict[str, float | None] = {s: mean(v) for s, v in by_split.items()}
    weights = {s: splits.get(s, (1.0, {}))[0] for s in by_split}
    if len(by_split) == 1:
        row["final"] = mean([100.0 * r.score.total for r in results])
    else:
        total_w = sum(weights.values())
        row["final"] = sum(weights[s] * (row[s] or 0.0) for s in by_split) / total_w
    keys = {k for r in results for k in r.score.metrics}
    for k in sorted(keys):
        vals = [r.score.metrics[k] for r in results if k in r.score.metrics]
        scale = 1.0 if k == "invalid_actions" else 100.0
        row[k] = None if not vals else scale * sum(vals) / len(vals)
    row["invalid_actions"] = mean(
        [r.stats.invalid_actions + sum(
            n for c, n in r.stats.protocol_errors.items() if c != "invalid_action")
         for r in results])
    row.update(resource_columns(results))
    return row
