"""Pictures for organizers: a scenario's preview and an episode's trajectory (PNG).

    preview(spec, seed, split, out_dir) -> [out_dir/track1-<split>-<seed>.png]
    trajectory_png(episode_dir) -> episode_dir/host/trajectory.png

Each picture has a title (track, split, seed, and the outcome or the task), the house from
above with a legend for every colour and marker, and a 1 m scale bar. Markers: what a goal
fetches (magenta ring), where it goes or what it acts on (cyan ring), where the exception
happened (red ring). Trajectories, from the odometry the agent observed: exploration blue,
planning (no motion) grey, execution orange.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path
from typing import Any

import numpy as np

from plugins._picture_log import read_episode, title_lines
from plugins.track1._types import Task, Track1Scenario
from simhost.host import ExceptionEvent, HostEventModel, ScenarioRecord

ITEM, GOAL, EXCEPTION = (220, 0, 200), (0, 170, 210), (220, 20, 20)
STAGE_COLOURS = {"exploration": (30, 90, 220), "planning": (120, 120, 120),
                 "execution": (240, 120, 0)}
Colour = tuple[int, int, int]
_LINE = 14  # pixels per line of size-2 text
PREVIEW_CAMERA = (256, 192)
"""(width, height) of the preview's camera frame on a split whose robot has no camera."""


class _Overlay:
    """Draws over a top-down picture in house coordinates."""

    def __init__(self, img: np.ndarray, height_m: float) -> None:
        from simhost.worlds.track1 import TOPDOWN_MARGIN, TOPDOWN_SCALE

        self.img, self.height_m = img, height_m
        self.scale, self.margin = TOPDOWN_SCALE, TOPDOWN_MARGIN

    def px(self, x: float, y: float) -> tuple[float, float]:
        return self.margin + x * self.scale, self.margin + (self.height_m - y) * self.scale

    def disc(self, x: float, y: float, r_px: float, colour: Colour, inner_px: float = 0.0
             ) -> None:
        cx, cy = self.px(x, y)
        h, w = self.img.shape[:2]
        j0, j1 = max(0, int(cy - r_px - 1)), min(h, int(cy + r_px + 2))
        i0, i1 = max(0, int(cx - r_px - 1)), min(w, int(cx + r_px + 2))
        if i1 <= i0 or j1 <= j0:
            return
        jj, ii = np.mgrid[j0:j1, i0:i1]
        d2 = (ii + 0.5 - cx) ** 2 + (jj + 0.5 - cy) ** 2
        self.img[j0:j1, i0:i1][(d2 <= r_px * r_px) & (d2 >= inner_px * inner_px)] = colour

    def ring(self, x: float, y: float, colour: Colour) -> None:
        self.disc(x, y, 0.45 * self.scale, colour, inner_px=0.45 * self.scale - 4)

    def polyline(self, points: list[tuple[float, float]], colour: Colour) -> None:
        for (x0, y0), (x1, y1) in zip(points, points[1:], strict=False):
            n = max(2, int(math.hypot(x1 - x0, y1 - y0) * self.scale))
            for t in np.linspace(0.0, 1.0, n):
                self.disc(x0 + (x1 - x0) * t, y0 + (y1 - y0) * t, 1.6, colour)


def _mark_task(overlay: _Overlay, layout: Any, task: Task) -> None:
    for goal in task.goals:
        for entity_id, colour in ((goal.fetched, ITEM), (goal.destination, GOAL)):
            e = layout.entity(entity_id)
            if hasattr(e, "receptacle"):
                x, y, _ = layout.item_position(e, e.receptacle, e.slot)
            else:
                x, y = e.pos
            overlay.ring(x, y, colour)


def _framed(img: np.ndarray, title: list[str], legend: list[tuple[str, Colour]]) -> np.ndarray:
    """The picture with its title above, and its legend and a 1 m scale bar below."""
    from simhost.worlds.track1 import TOPDOWN_SCALE, draw_text

    width = max(img.shape[1], 420)
    entries: list[list[tuple[str, Colour]]] = [[]]
    x = 8
    for label, colour in legend:
        need = 18 + 8 * len(label) + 12
        if x + need > width - 8:
            entries.append([])
            x = 8
        entries[-1].append((label, colour))
        x += need
    title = title_lines(title, width)
    top = 8 + _LINE * len(title)
    bottom = 8 + _LINE * (len(entries) + 1) + 8
    out = np.full((top + img.shape[0] + bottom, width, 3), 255, np.uint8)
    for k, line in enumerate(title):
        draw_text(out, 8, 6 + _LINE * k, line)
    out[top:top + img.shape[0], :img.shape[1]] = img
    y = top + img.shape[0] + 8
    for row in entries:
        x = 8
        for label, colour in row:
            out[y:y + 10, x:x + 10] = colour
            out[y:y + 10, x:x + 1] = out[y:y + 10, x + 9:x + 10] = 0
            out[y:y + 1, x:x + 10] = out[y + 9:y + 10, x:x + 10] = 0
            x = draw_text(out, x + 16, y, label) + 12
        y += _LINE
    bar = int(round(TOPDOWN_SCALE))
    out[y + 4:y + 7, 8:8 + bar] = 0
    out[y:y + 11, 8:9] = out[y:y + 11, 8 + bar - 1:8 + bar] = 0
    draw_text(out, 16 + bar, y + 1, "1 M")
    return out


def _legend(*extra: tuple[str, Colour]) -> list[tuple[str, Colour]]:
    from simhost.worlds.track1 import TOPDOWN_LEGEND

    return [*TOPDOWN_LEGEND, ("goal item", ITEM), ("goal place", GOAL), *extra]


def _side_by_side(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    h = max(left.shape[0], right.shape[0])
    out = np.full((h, left.shape[1] + right.shape[1] + 8, 3), 255, np.uint8)
    out[: left.shape[0], : left.shape[1]] = left
    out[: right.shape[0], left.shape[1] + 8:] = right
    return out


def preview(spec: Track1Scenario, seed: int, split: str, out_dir: str | Path) -> list[Path]:
    """A scenario's preview (``spec``, made from ``seed`` on ``split``): the top-down map
    (the goals marked) beside the robot's first camera frame, titled with the split, the
    seed and the instruction. The frame is the split's own size, pixel for pixel what the
    agent gets (a split without a camera, ``dev``: ``PREVIEW_CAMERA``). Returns its path."""
    from simhost.worlds.track1 import HouseEnv, render_topdown, write_png

    sensing = spec.split.config
    size = sensing.image_size if sensing.render_rgbd else PREVIEW_CAMERA
    env = HouseEnv(split=spec.split, render_rgbd=True, image_size=size, field_of_view=360.0)
    try:
        env.reset(seed=seed)
        x, y, _ = env.layout.start
        cx, cy = env.layout.rooms[env.layout.start_room].centre
        env.teleport_robot(x, y, math.atan2(cy - y, cx - x))  # look into the room
        obs = env.step({"primitive": 0})[0]
        top = render_topdown(env)
        _mark_task(_Overlay(top, env.layout.extent[1]), env.layout, spec.task)
        picture = _side_by_side(top, np.asarray(obs["rgb"], np.uint8))
    finally:
        env.close()
    exc = spec.exception.type.replace("_", " ") if spec.exception else "no exception"
    wrap = max(20, picture.shape[1] // 8 - 2)
    title = [f"TRACK1 {split} seed {seed}: preview ({spec.rooms} rooms, {exc})",
             *textwrap.wrap(f"task: {spec.task.text}", wrap),
             f"left: the house from above. right: the first camera frame, {size[0]}x{size[1]}"
             + ("" if sensing.render_rgbd else f" (the {split} split has no camera)")]
    picture = _framed(picture, title, _legend())
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"track1-{split}-{seed}.png"
    write_png(path, picture)
    return [path]


def _read_mcap(path: Path) -> tuple[ScenarioRecord, list[tuple[int, list[float]]],
                                    list[tuple[int, HostEventModel]], float | None]:
    log = read_episode(path, "odometry")
    return log.scenario, log.poses, log.events, log.total


def trajectory_png(episode_dir: str | Path) -> Path:
    """Draws an episode's robot trajectory over its house from ``host/episode.mcap``;
    writes ``host/trajectory.png`` and returns its path."""
    from simhost.worlds.track1 import generate_house, render_topdown, write_png

    host = Path(episode_dir) / "host"
    mcap = host / "episode.mcap"
    if not mcap.is_file():
        raise FileNotFoundError(f"{mcap} does not exist: is {episode_dir} an episode folder?")
    log = read_episode(mcap, "odometry")
    scenario, poses, total = log.scenario, log.poses, log.total
    if scenario.track != "track1":
        raise ValueError(f"{mcap} is a {scenario.track!r} episode, not track1")
    spec = Track1Scenario.of(scenario)
    layout = generate_house(scenario.seed, params=spec.split.params)
    img = render_topdown(layout)
    overlay = _Overlay(img, layout.extent[1])
    _mark_task(overlay, layout, spec.task)
    starts = log.stage_starts()
    for k, (t0, stage) in enumerate(starts):
        t1 = starts[k + 1][0] if k + 1 < len(starts) else math.inf
        points = [(p[0], p[1]) for t, p in poses if t0 <= t < t1]
        overlay.polyline(points, STAGE_COLOURS.get(stage, (0, 0, 0)))
    for _, e in log.events:
        if isinstance(e, ExceptionEvent) and e.pose:
            overlay.ring(e.pose[0], e.pose[1], EXCEPTION)
    end = log.end_reason()
    score = "not scored" if total is None else f"score {100 * total:.1f}"
    title = [f"TRACK1 {scenario.split} seed {scenario.seed}: {end}, {score}",
             *textwrap.wrap(f"task: {spec.task.text}", max(20, img.shape[1] // 8 - 2))]
    legend = _legend(("exception", EXCEPTION),
                     *((f"{s} path", c) for s, c in STAGE_COLOURS.items()))
    path = host / "trajectory.png"
    write_png(path, _framed(img, title, legend))
    return path
