"""Pictures for organizers: a scenario's preview and an episode's trajectory (PNG).

    preview(seed, split, out_dir) -> [out_dir/track1-<split>-<seed>.png]
    trajectory_png(episode_dir) -> episode_dir/host/trajectory.png

Markers: the task's item (magenta ring), where it must go or what it acts on (cyan ring),
the exception's place (red ring). Trajectories: exploration blue, planning (no motion)
grey, execution orange.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from plugins.track1._types import Task, Track1Scenario

SCALE, MARGIN = 48.0, 12  # as simhost.track1.render_topdown draws
ITEM, GOAL, EXCEPTION = (220, 0, 200), (0, 170, 210), (220, 20, 20)
STAGE_COLOURS = {"exploration": (30, 90, 220), "planning": (120, 120, 120),
                 "execution": (240, 120, 0)}


class _Overlay:
    """Draws over a top-down picture in house coordinates."""

    def __init__(self, img: np.ndarray, height_m: float) -> None:
        self.img, self.height_m = img, height_m

    def px(self, x: float, y: float) -> tuple[float, float]:
        return MARGIN + x * SCALE, MARGIN + (self.height_m - y) * SCALE

    def disc(self, x: float, y: float, r_px: float, colour: tuple[int, int, int],
             inner_px: float = 0.0) -> None:
        cx, cy = self.px(x, y)
        h, w = self.img.shape[:2]
        j0, j1 = max(0, int(cy - r_px - 1)), min(h, int(cy + r_px + 2))
        i0, i1 = max(0, int(cx - r_px - 1)), min(w, int(cx + r_px + 2))
        if i1 <= i0 or j1 <= j0:
            return
        jj, ii = np.mgrid[j0:j1, i0:i1]
        d2 = (ii + 0.5 - cx) ** 2 + (jj + 0.5 - cy) ** 2
        self.img[j0:j1, i0:i1][(d2 <= r_px * r_px) & (d2 >= inner_px * inner_px)] = colour

    def ring(self, x: float, y: float, colour: tuple[int, int, int]) -> None:
        self.disc(x, y, 0.45 * SCALE, colour, inner_px=0.45 * SCALE - 4)

    def polyline(self, points: list[tuple[float, float]], colour: tuple[int, int, int]) -> None:
        for (x0, y0), (x1, y1) in zip(points, points[1:], strict=False):
            n = max(2, int(math.hypot(x1 - x0, y1 - y0) * SCALE))
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


def _side_by_side(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    h = max(left.shape[0], right.shape[0])
    out = np.full((h, left.shape[1] + right.shape[1] + 8, 3), 255, np.uint8)
    out[: left.shape[0], : left.shape[1]] = left
    out[: right.shape[0], left.shape[1] + 8:] = right
    return out


def preview(seed: int, split: str, out_dir: str | Path) -> list[Path]:
    """A scenario's preview: the top-down map (task marked) beside the robot's first camera
    frame. Returns the PNG's path."""
    from plugins.track1._track import Track1
    from simhost.track1 import HouseEnv, render_topdown, write_png

    scenario = Track1().make_scenario(seed=seed, split=split, params={})
    spec = Track1Scenario.model_validate(scenario.params)
    env = HouseEnv(split=spec.split, render_rgbd=True, image_size=(320, 240), field_of_view=360.0)
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
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"track1-{split}-{seed}.png"
    write_png(path, picture)
    return [path]


def _read_mcap(path: Path) -> tuple[dict[str, Any], list[tuple[int, list[float]]],
                                    list[tuple[int, dict[str, Any]]]]:
    from mcap.reader import make_reader

    scenario: dict[str, Any] = {}
    poses: list[tuple[int, list[float]]] = []
    events: list[tuple[int, dict[str, Any]]] = []
    with path.open("rb") as f:
        for _, channel, message in make_reader(f).iter_messages(
                topics=["/eagc/scenario", "/eagc/observation", "/eagc/event"]):
            doc = json.loads(message.data)
            if channel.topic == "/eagc/scenario":
                scenario = doc
            elif channel.topic == "/eagc/observation" and "odometry" in doc:
                poses.append((message.log_time, doc["odometry"]))
            elif channel.topic == "/eagc/event":
                events.append((message.log_time, doc))
    return scenario, poses, events


def trajectory_png(episode_dir: str | Path) -> Path:
    """Draws an episode's robot trajectory over its house from ``host/episode.mcap``;
    writes ``host/trajectory.png`` and returns its path."""
    from simhost.track1 import generate_house, render_topdown, write_png

    host = Path(episode_dir) / "host"
    mcap = host / "episode.mcap"
    if not mcap.is_file():
        raise FileNotFoundError(f"{mcap} does not exist: is {episode_dir} an episode folder?")
    scenario, poses, events = _read_mcap(mcap)
    if scenario.get("track") != "track1":
        raise ValueError(f"{mcap} is a {scenario.get('track')!r} episode, not track1")
    spec = Track1Scenario.model_validate(scenario["params"])
    layout = generate_house(int(scenario["seed"]), params=spec.split.params)
    img = render_topdown(layout)
    overlay = _Overlay(img, layout.extent[1])
    _mark_task(overlay, layout, spec.task)
    starts = sorted((t, e["stage"]) for t, e in events if e.get("event") == "stage_start")
    for k, (t0, stage) in enumerate(starts):
        t1 = starts[k + 1][0] if k + 1 < len(starts) else math.inf
        points = [(p[0], p[1]) for t, p in poses if t0 <= t < t1]
        overlay.polyline(points, STAGE_COLOURS.get(stage, (0, 0, 0)))
    for _, e in events:
        if e.get("event") == "exception" and e.get("pose"):
            overlay.ring(e["pose"][0], e["pose"][1], EXCEPTION)
    path = host / "trajectory.png"
    write_png(path, img)
    return path
