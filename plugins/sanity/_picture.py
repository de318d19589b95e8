"""The picture of a sanity episode (PNG): the arena from above, the point robot's path
(explore blue, reach orange) from the positions it observed, its start, the target (and
where the exception moved it), a title (split, seed, how it ended, the score), a legend and
a 1 m scale bar.

    path_png(episode_dir) -> episode_dir/host/path.png
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict

from plugins._picture_log import read_episode, title_lines
from simhost.host import ExceptionEvent

HALF = 2.0  # the arena's walls at ±2 m
SCALE = 80  # pixels per metre
MARGIN = 12
START, TARGET, MOVED = (40, 160, 40), (220, 0, 200), (220, 20, 20)
STAGE_COLOURS = {"explore": (30, 90, 220), "reach": (240, 120, 0)}
Colour = tuple[int, int, int]
_LINE = 14  # pixels per line of size-2 text


class _Drawn(BaseModel):
    """What the picture draws of the hidden scenario (its ``params``; the rest ignored)."""

    model_config = ConfigDict(frozen=True, extra="ignore")

    start: list[float] | None = None
    target: list[float] | None = None
    moved_target: list[float] | None = None
    """Where the exception moves the target (None: no exception)."""


def _px(x: float, y: float) -> tuple[float, float]:
    return MARGIN + (x + HALF) * SCALE, MARGIN + (HALF - y) * SCALE


def _disc(img: np.ndarray, x: float, y: float, r: float, colour: Colour,
          inner: float = 0.0) -> None:
    cx, cy = _px(x, y)
    jj, ii = np.mgrid[0:img.shape[0], 0:img.shape[1]]
    d2 = (ii + 0.5 - cx) ** 2 + (jj + 0.5 - cy) ** 2
    img[(d2 <= r * r) & (d2 >= inner * inner)] = colour


def _polyline(img: np.ndarray, points: list[list[float]], colour: Colour) -> None:
    for a, b in zip(points, points[1:], strict=False):
        (x0, y0), (x1, y1) = _px(*a), _px(*b)
        n = max(2, int(max(abs(x1 - x0), abs(y1 - y0)) * 2) + 1)
        for t in np.linspace(0.0, 1.0, n):
            i, j = int(x0 + t * (x1 - x0)), int(y0 + t * (y1 - y0))
            img[max(0, j - 1):j + 2, max(0, i - 1):i + 2] = colour


def path_png(episode_dir: str | Path) -> Path:
    """Draws a sanity episode from ``host/episode.mcap``; writes ``host/path.png``."""
    from simhost.host import write_png
    from simhost.worlds.track1 import draw_text

    host = Path(episode_dir) / "host"
    mcap = host / "episode.mcap"
    if not mcap.is_file():
        raise FileNotFoundError(f"{mcap} does not exist: is {episode_dir} an episode folder?")
    log = read_episode(mcap, "position")
    scenario, points, events, total = log.scenario, log.poses, log.events, log.total
    if scenario.track != "sanity":
        raise ValueError(f"{mcap} is a {scenario.track!r} episode, not sanity")
    params = _Drawn.model_validate(scenario.params)
    side = int(2 * HALF * SCALE) + 2 * MARGIN
    arena = np.full((side, side, 3), 255, np.uint8)
    lo, hi = MARGIN, MARGIN + int(2 * HALF * SCALE)
    for k in range(1, int(2 * HALF)):  # a 1 m grid
        arena[lo:hi, lo + k * SCALE] = arena[lo + k * SCALE, lo:hi] = (225, 225, 225)
    arena[lo:hi, lo:lo + 2] = arena[lo:hi, hi - 2:hi] = 0  # the walls
    arena[lo:lo + 2, lo:hi] = arena[hi - 2:hi, lo:hi] = 0
    starts = log.stage_starts()
    for k, (t0, stage) in enumerate(starts):
        t1 = starts[k + 1][0] if k + 1 < len(starts) else float("inf")
        # from the last point before the stage, so that the path has no gap
        before = [p for t, p in points if t < t0][-1:]
        _polyline(arena, before + [p for t, p in points if t0 <= t < t1],
                  STAGE_COLOURS.get(stage, (0, 0, 0)))
    if params.start:
        _disc(arena, *params.start, 6, START)
    if params.target:
        _disc(arena, *params.target, 0.5 * SCALE, TARGET, inner=0.5 * SCALE - 3)
        _disc(arena, *params.target, 4, TARGET)
    moved = any(isinstance(e, ExceptionEvent) for _, e in events)
    if moved and params.moved_target:
        _disc(arena, *params.moved_target, 0.5 * SCALE, MOVED, inner=0.5 * SCALE - 3)
        _disc(arena, *params.moved_target, 4, MOVED)
    end = log.end_reason()
    score = "not scored" if total is None else f"score {100 * total:.1f}"
    text = f"SANITY {scenario.split} seed {scenario.seed}: {end}, {score}"
    width = max(side, min(16 + 8 * len(text), 640))  # the title on one line where it can
    title = title_lines([text], width)
    legend: list[tuple[str, Colour]] = [("start", START), ("target", TARGET),
                                        *((f"{s} path", c) for s, c in STAGE_COLOURS.items())]
    if moved:
        legend.insert(2, ("target moved", MOVED))
    rows: list[list[tuple[str, Colour]]] = [[]]
    x = 8
    for label, colour in legend:
        need = 18 + 8 * len(label) + 12
        if x + need > width - 8:
            rows.append([])
            x = 8
        rows[-1].append((label, colour))
        x += need
    top = 8 + _LINE * len(title)
    out = np.full((top + side + 8 + _LINE * (len(rows) + 1) + 8, width, 3), 255, np.uint8)
    for k, line in enumerate(title):
        draw_text(out, 8, 6 + _LINE * k, line)
    out[top:top + side, :side] = arena
    y = top + side + 8
    for row in rows:
        x = 8
        for label, colour in row:
            out[y:y + 10, x:x + 10] = colour
            x = draw_text(out, x + 16, y, label) + 12
        y += _LINE
    out[y + 4:y + 7, 8:8 + SCALE] = 0  # the 1 m scale bar
    out[y:y + 11, 8:9] = out[y:y + 11, 8 + SCALE - 1:8 + SCALE] = 0
    draw_text(out, 16 + SCALE, y + 1, "1 M")
    path = host / "path.png"
    write_png(path, out)
    return path
