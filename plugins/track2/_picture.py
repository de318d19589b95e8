"""Pictures of a recorded Track 2 episode: an attempt beside the demonstration.

``attempt_png`` draws one attempt (``Track2.picture``); ``attempt_pictures`` draws each,
with the steps it spans, for the episode viewer (``Track2.step_pictures``). Both read the
episode's MCAP log (``host/episode.mcap``) once, in log-time order: ``/eagc/scenario`` for
the source and demonstration seed, ``/eagc/reply`` for the stage and attempt of every reply,
the ``/eagc/observation`` that follows each reply for the hand's position, and the state
hashes for the host's step. The demonstration comes from the episode's ``input/demo``
folder, or (``attempt_png``) is written again from the scenario (the same source and seed
give the same packet) when that folder is gone.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict

from plugins._base import Scenario
from plugins._views import RecordedEpisode, StepPicture
from plugins.track2._episode import DEMO_FOLDER, EXECUTION
from plugins.track2._scenario import Track2Scenario
from schemas import EpisodeResult, ErrorReply, HelloReply, ObservationReply
from simhost.host import (
    AttemptEndEvent,
    McapRecordError,
    ScenarioRecord,
    SmallTensors,
    StateHash,
    read_records,
)

#: The widest title the picture holds (8 pixels a character, 12 of margin each side).
TITLE_CHARS = 82


class _Titled(BaseModel):
    """What the title reads of the hidden scenario (``Track2Scenario``'s fields, read
    without the rest, so that a title is drawn for any version of it)."""

    model_config = ConfigDict(frozen=True, extra="ignore")

    family: str = ""
    max_attempts: int = 3


@dataclass
class _Log:
    """What the pictures read of an episode's log."""

    scenario: ScenarioRecord
    #: Attempt → the hand's path, one ``[step, x, y, z]`` per observation of the attempt.
    paths: dict[int, list[list[float]]] = field(default_factory=dict)
    #: The attempt that succeeded (None: none did).
    won: int | None = None
    #: The episode's score (0-1, from its EpisodeResult; None before it was scored).
    total: float | None = None

    def xyz(self, attempt: int) -> np.ndarray:
        """The hand's path in one attempt, N×3."""
        return np.asarray([p[1:] for p in self.paths[attempt]])


def _read_log(mcap: Path) -> _Log:
    """The scenario, the hand's path per attempt, the attempt that succeeded and the score."""
    scenario: ScenarioRecord | None = None
    total: float | None = None
    won: int | None = None
    paths: dict[int, list[list[float]]] = {}
    current: int | None = None
    step = 0
    for record in read_records(mcap):
        match record.body:
            case ScenarioRecord() as scenario:
                pass
            case EpisodeResult() as result:
                total = result.score.total
            case StateHash() as hashed:
                step = hashed.step
            case HelloReply() | ErrorReply():
                current = None
            case ObservationReply() as reply:
                current = None
                if reply.stage == EXECUTION:
                    current = int(reply.observation.get("attempt") or 0) or None
            case AttemptEndEvent() as ended if ended.success:
                won = ended.index
            case SmallTensors() as tensors if current is not None:
                proprio = tensors.vector("proprio")
                if proprio:
                    paths.setdefault(current, []).append([step, *proprio[:3]])
    if scenario is None:
        raise McapRecordError(f"{mcap}: no /eagc/scenario message: not an eagc episode log")
    return _Log(scenario, paths, won, total)


def _title(scenario: ScenarioRecord, k: int, won: int | None, total: float | None) -> str:
    """Track, seed, split, family, the attempt and the score, within ``TITLE_CHARS``."""
    hidden = _Titled.model_validate(scenario.params)
    score = "NOT SCORED" if total is None else f"SCORE {100 * total:.1f}/100"
    head = f"TRACK2 SEED {scenario.seed} {scenario.split.upper()}"
    family = hidden.family.upper().replace("_", " ")
    verdict = "SUCCEEDED" if k == won else "FAILED"
    n = hidden.max_attempts
    for attempt in (f"ATTEMPT {k} OF {n} {verdict}", f"ATT {k}/{n} {verdict}"):
        title = f"{head} {family} {attempt} {score}"
        if len(title) <= TITLE_CHARS:
            return title
    return f"{head} {score}"[:TITLE_CHARS]


def _with_axis_values(png: bytes, demo_xyz: np.ndarray, attempt_xyz: np.ndarray,
                      panel: int = 320) -> np.ndarray:
    """The picture of ``render_attempt_vs_demo`` with the range of each panel's axes in
    metres: horizontal (X) under the panel, vertical (Y, Z) at its right edge. The extent
    is the one that function draws: both paths' bounding box, widened 15 %."""
    from simhost.worlds.track2 import Canvas, decode_png

    both = np.vstack([demo_xyz[:, :3], attempt_xyz[:, :3]])
    lo, hi = both.min(axis=0), both.max(axis=0)
    span = float(max(np.max(hi - lo), 0.05)) * 1.15
    centre = (lo + hi) / 2
    c = Canvas(1, 1, (255, 255, 255))
    c.img = decode_png(png).copy()
    head, margin, grey = 58, 12, (90, 90, 90)
    y0 = head + margin
    for k, (axis, name) in enumerate(((1, "Y"), (2, "Z"))):
        x0 = margin + k * (panel + margin)
        left, right = (f"X {centre[0] - span / 2:.3f} M", f"{centre[0] + span / 2:.3f} M")
        c.text(y0 + panel + 3, x0, left, grey, scale=1)
        c.text(y0 + panel + 3, x0 + panel - 4 * len(right), right, grey, scale=1)
        top = f"{name} {centre[axis] + span / 2:.3f}"
        bottom = f"{name} {centre[axis] - span / 2:.3f}"
        c.text(y0 + 4, x0 + panel - 4 - 4 * len(top), top, grey, scale=1)
        c.text(y0 + panel - 10, x0 + panel - 4 - 4 * len(bottom), bottom, grey, scale=1)
    return c.img


def _draw(demo: Path, attempt_xyz: np.ndarray, out: Path, title: str) -> None:
    from simhost import write_png
    from simhost.worlds.track2 import read_demo_packet, render_attempt_vs_demo

    png = render_attempt_vs_demo(demo, attempt_xyz, title=title)
    demo_xyz = np.asarray(read_demo_packet(demo).arrays["obs_proprio"], dtype=float)
    write_png(out, _with_axis_values(png, demo_xyz, attempt_xyz))


def attempt_png(
    episode_dir: str | Path, *, attempt: int | None = None, path: str | Path | None = None
) -> Path:
    """Draw one attempt of a Track 2 episode against its demonstration; return the PNG's path.

    Args:
      episode_dir: the episode's folder (``<runs>/<episode>``, holding ``host/episode.mcap``).
      attempt: which attempt (1-based); default the successful one, else the last.
      path: where to write; default ``<episode_dir>/host/attempt_<k>.png``.

    Raises:
      FileNotFoundError: no MCAP log in the folder.
      ValueError: not a Track 2 episode, or the attempt has no recorded step.
    """
    from simhost.worlds.track2 import write_demo_packet

    root = Path(episode_dir)
    mcap = root / "host" / "episode.mcap"
    if not mcap.is_file():
        raise FileNotFoundError(f"{mcap} does not exist: is {root} an episode folder?")
    log = _read_log(mcap)
    scenario, paths = log.scenario, log.paths
    if scenario.track != "track2":
        raise ValueError(f"{root} is a {scenario.track!r} episode, not track2")
    if not paths:
        raise ValueError(f"{root}: the agent never reached the execution stage; nothing to draw")
    k = attempt or log.won or max(paths)
    if k not in paths:
        raise ValueError(f"{root}: attempt {k} has no recorded step (attempts: {sorted(paths)})")
    out = Path(path) if path is not None else root / "host" / f"attempt_{k}.png"
    demo = root / "input" / DEMO_FOLDER
    attempt_xyz = log.xyz(k)
    title = _title(scenario, k, log.won, log.total)
    if (demo / "manifest.json").is_file():
        _draw(demo, attempt_xyz, out, title)
        return out
    hidden = Track2Scenario.of(scenario)
    with tempfile.TemporaryDirectory() as tmp:
        write_demo_packet(Path(tmp) / DEMO_FOLDER, hidden.source, seed=hidden.demo_seed,
                          config=hidden.bench, frames=hidden.demo_frames)
        _draw(Path(tmp) / DEMO_FOLDER, attempt_xyz, out, title)
    return out


def attempt_pictures(episode: RecordedEpisode) -> list[StepPicture]:
    """Each attempt of the episode beside the demonstration, with the steps it spans (the
    viewer's pictures; none before execution). Raises ``FileNotFoundError`` when the
    episode folder holds no demonstration (``input/demo``)."""
    from simhost.worlds.track2 import render_attempt_vs_demo

    log = _read_log(episode.folder / "host" / "episode.mcap")
    if not log.paths:
        return []
    demo = episode.folder / "input" / DEMO_FOLDER
    if not (demo / "manifest.json").is_file():
        raise FileNotFoundError("no demonstration in this episode folder (input/demo)")
    out = []
    for k, path in sorted(log.paths.items()):
        first, last = int(path[0][0]), int(path[-1][0])
        out.append(StepPicture(
            first_step=first, last_step=last,
            caption=f"attempt {k} (steps {first}–{last}) beside the demonstration",
            png=render_attempt_vs_demo(demo, log.xyz(k), title=f"ATTEMPT {k}")))
    return out


def preview_png(scenario: Scenario[Track2Scenario], out: Path) -> Path:
    """The demonstrated source beside the hidden instance of a (public) seed: a top view of
    their parts (blue: source, orange: instance; 5 cm scale bar) over the overview camera's
    picture of each, titled with track, seed, split and family. Returns the PNG's path."""
    from simhost.worlds.track2 import (
        ATTEMPT_RGB,
        DEMO_RGB,
        INK,
        PAPER,
        BenchEnv,
        Canvas,
        resize_rgb,
    )

    hidden = Track2Scenario.of(scenario)
    shots, rows = [], []
    for params in (hidden.source, hidden.instance):
        env = BenchEnv(params, config=hidden.bench, render_mode="rgb_array",
                       image_size=(240, 320))
        env.reset(seed=hidden.demo_seed)
        shots.append(env.render())
        rows.append((env.task.part_names, env.task.parts()))
        env.close()
    panel, margin, head = 320, 12, 58
    width = 2 * panel + 3 * margin
    c = Canvas(head + panel + 2 * margin + 240 + margin, width, PAPER)
    c.text(6, margin, f"TRACK2 PREVIEW SEED {scenario.seed} {scenario.split.upper()} "
           f"{hidden.family.upper().replace('_', ' ')}", INK)
    c.rect(26, margin, 36, margin + 10, DEMO_RGB)
    c.text(26, margin + 16, "DEMONSTRATED SOURCE", INK)
    c.rect(26, margin + 190, 36, margin + 200, ATTEMPT_RGB)
    c.text(26, margin + 206, "HIDDEN INSTANCE", INK)
    y0, x0 = head, margin
    c.rect(y0, x0, y0 + panel, x0 + panel, (255, 255, 255))
    c.text(y0 + 4, x0 + 4, "TOP X-Y", (120, 120, 120))
    span = 0.5  # m across the panel: the table's working area

    def px(x: float, y: float) -> tuple[float, float]:
        return y0 + (0.5 - y / span) * (panel - 1), x0 + (0.5 + (x - 0.05) / span) * (panel - 1)

    for (names, parts), colour in zip(rows, (DEMO_RGB, ATTEMPT_RGB), strict=True):
        for name, row in zip(names, parts, strict=True):
            if row[0] > 0.5:
                yy, xx = px(float(row[1]), float(row[2]))
                c.disc(yy, xx, 5, colour)
                c.text(int(yy) + 7, int(xx) - 8, name[:6], colour, scale=1)
    bar = int(round(0.05 / span * (panel - 1)))
    c.rect(y0 + panel - 12, x0 + 8, y0 + panel - 9, x0 + 8 + bar, INK)
    c.text(y0 + panel - 26, x0 + 8, "5 CM", INK)
    side = [
        "PARTS AS NAMED DISCS", "",
        f"DISTANCE {hidden.distance:.2f}: HOW FAR", "THE INSTANCE IS FROM THE SOURCE",
        "(0: THE SAME  1: THE MOST APART)", "",
        f"DRAWS {hidden.draws}: INSTANCES DRAWN", "UNTIL THE EXPERT SOLVED ONE", "",
        "BELOW: OVERVIEW CAMERA", "LEFT SOURCE  RIGHT INSTANCE"]
    for i, line in enumerate(side):
        c.text(y0 + 4 + 16 * i, x0 + panel + margin, line, INK)
    ys = head + panel + 2 * margin
    half = (width - 3 * margin) // 2
    for k, img in enumerate(shots):
        c.blit(ys, margin + k * (half + margin), resize_rgb(img, half))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"track2_preview_seed{scenario.seed}_{scenario.split}.png"
    from simhost import write_png

    write_png(path, c.img)
    return path
