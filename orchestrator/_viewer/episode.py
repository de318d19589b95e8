"""One episode folder, read for its page: timeline, frames, path, snapshots, score.

Reads ``host/result.json``, ``host/episode.mcap`` (replies, events, steps, camera frames,
poses), ``host/output/episode_log.jsonl``, ``host/snapshots/<stage>/*.json`` and
``host/agent.log``. The team's view (``organizer=False``) keeps what the team may see: no
seed, no scenario parameters, no organizer path, and of the host's events only their
name, stage, step and outcome (an exception's type and step, never its subject or place).

What only a track knows it adds through its plugin's hooks (``plugins._views``), each given
a ``plugins.RecordedEpisode`` that says whose view it is: the map under the path
(``episode_map``; Track 1: the house's plan, without the objects and tools in a team's
view), pictures of spans of steps (``step_pictures``; Track 2: each attempt beside the
demonstration) and, for organizers, the track's own picture of the episode (``picture``)
and the agent's model against the truth (``truth``). The organizer's view adds the hidden
scenario.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from orchestrator._viewer import frames as fr
from plugins import RecordedEpisode, TrackPlugin, load_track
from schemas import EpisodeResult, ObservationReply, SchemaError
from simhost.host import (
    CompressedImage,
    FrameTransforms,
    FullState,
    HostEventModel,
    McapRecordError,
    OutputFile,
    RawImage,
    ScenarioRecord,
    StageEndEvent,
    StageStartEvent,
    StateHash,
    read_records,
)

#: Lines of the agent's own log shown at the end of the page.
LOG_TAIL_LINES = 60
#: Poses kept for the drawn path (evenly thinned beyond it).
MAX_PATH = 2000
#: The host event fields a team sees; the rest may tell what the scenario held.
TEAM_FIELDS = ("stage", "index", "ended_by", "type", "reason", "success", "count", "step")
#: Changes listed per snapshot file, at most.
MAX_CHANGES = 200
#: Records of the agent's episode_log.jsonl on the timeline, at most (a page stays small).
MAX_AGENT_RECORDS = 1000
#: Characters of one snapshot shown, at most.
MAX_SNAPSHOT_CHARS = 100_000


@dataclass(frozen=True)
class Event:
    """One line of the timeline: ``source`` is ``host``, ``action`` or ``agent``."""

    step: int
    source: str
    name: str
    text: str
    stage: str = ""


@dataclass(frozen=True)
class Snapshot:
    """One ``/output`` file as a stage ended, and what changed from the one before."""

    stage: str
    name: str
    text: str
    changes: tuple[str, ...]
    first: bool


@dataclass
class EpisodeView:
    """Everything one episode page shows."""

    id: str
    result: EpisodeResult
    organizer: bool
    #: The scenario's seed where it is public (``run-episode``'s) or for organizers.
    seed: int | None = None
    last_step: int = 0
    stages: list[dict[str, Any]] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    frames: list[dict[str, object]] = field(default_factory=list)
    path: list[list[float]] = field(default_factory=list)
    map_image: str | None = None
    #: The map's transform: pixel = (ox + x * scale, oy - y * scale); width, height.
    map_frame: dict[str, float] | None = None
    map_caption: str = ""
    #: Pictures of spans of steps (``from``, ``to``, ``caption``, ``image``).
    pictures: list[dict[str, Any]] = field(default_factory=list)
    snapshots: list[Snapshot] = field(default_factory=list)
    log_tail: str = ""
    hidden: str | None = None
    picture: str | None = None
    #: Organizers only: the graded model against the hidden truth (``truth``).
    truth: list[str] = field(default_factory=list)
    truth_of: str = ""
    truth_note: str = ""
    problems: list[str] = field(default_factory=list)


def read_episode(folder: Path, *, organizer: bool, public_seed: bool = False) -> EpisodeView:
    """The view of the episode in ``folder`` (``<runs>/<episode>``)."""
    host = folder / "host"
    result = EpisodeResult.model_validate_json((host / "result.json").read_text())
    view = EpisodeView(id=result.episode, result=result, organizer=organizer)
    mcap = host / "episode.mcap"
    log = _Log()
    if mcap.is_file():
        log = _read_log(mcap, view)
    else:
        view.problems.append("no MCAP log in this episode folder: no frames, no timeline")
    _agent_log(host, view)
    _snapshots(host, result, view)
    _log_tail(host, result, view)
    if log.scenario is not None:
        if public_seed or organizer:
            view.seed = log.scenario.seed
        episode = RecordedEpisode(folder=folder, scenario=log.scenario, organizer=organizer,
                                  public_seed=public_seed)
        plugin = _plugin(log.scenario.track, view)
        if plugin is not None:
            _map(plugin, episode, view)
        if organizer:
            view.hidden = json.dumps(log.scenario.model_dump(mode="json",
                                                             exclude_unset=True),
                                     indent=2, default=str)
            if plugin is not None:
                _track_picture(plugin, folder, view)
                _truth(plugin, episode, view)
    view.events.sort(key=lambda e: (e.step, {"host": 0, "action": 1, "agent": 2}[e.source]))
    return view


# ------------------------------------------------------------------------------ the log
#: Problems with the log's records listed on the page, at most.
MAX_LOG_PROBLEMS = 5


@dataclass
class _Stage:
    name: str
    start: int
    end: int | None = None
    ended_by: str | None = None


@dataclass
class _Camera:
    """One camera frame's images, as logged at one time."""

    step: int
    rgb: CompressedImage | None = None
    depth: RawImage | None = None
    segmentation: CompressedImage | None = None


@dataclass
class _Log:
    """What the page reads of the MCAP log besides what it puts on the view."""

    scenario: ScenarioRecord | None = None


def _read_log(mcap: Path, view: EpisodeView) -> _Log:
    log = _Log()
    step, stage = 0, ""
    stages: list[_Stage] = []
    cameras: dict[int, _Camera] = {}
    path: list[list[float]] = []
    problems: list[McapRecordError] = []
    for record in read_records(mcap, on_problem=problems.append):
        match record.body:
            case FullState() | OutputFile():
                pass
            case ScenarioRecord() as scenario:
                log.scenario = scenario
            case StateHash() as hashed:
                step = hashed.step
            case ObservationReply() as reply:
                stage = reply.stage or stage
                if reply.action is not None and not reply.action.ok:
                    view.events.append(Event(step, "action", "action failed",
                                             reply.action.reason or "no reason given", stage))
            case FrameTransforms() as tf:
                robot = tf.of("robot")
                if robot is not None:
                    path.append([step, robot.translation.x, robot.translation.y])
            case CompressedImage() | RawImage() as image:
                camera = cameras.setdefault(record.log_time, _Camera(step))
                setattr(camera, record.topic.removeprefix("/camera/"), image)
            case event if record.topic == "/eagc/event":
                stage = _host_event(event, step, stage, stages, view)
    for problem in problems[:MAX_LOG_PROBLEMS]:
        view.problems.append(str(problem))
    if len(problems) > MAX_LOG_PROBLEMS:
        view.problems.append(f"… and {len(problems) - MAX_LOG_PROBLEMS} more records "
                             "that do not read")
    view.last_step = max(step, view.result.stats.steps)
    _close_stages(stages, view)
    while len(path) > MAX_PATH:
        path = path[::2]
    view.path = [[s, round(x, 3), round(y, 3)] for s, x, y in path]
    view.frames = fr.page_frames([_frame(c) for _, c in sorted(cameras.items())])
    return log


def _host_event(event: HostEventModel, step: int, stage: str, stages: list[_Stage],
                view: EpisodeView) -> str:
    match event:
        case StageStartEvent():
            stage = event.stage
            stages.append(_Stage(stage, step))
        case StageEndEvent() if stages:
            stages[-1].end, stages[-1].ended_by = step, event.ended_by
    at = event.at_step if event.at_step is not None else step
    shown = {k: v for k, v in event.fields().items() if k != "episode"
             and (view.organizer or k in TEAM_FIELDS)}
    text = ", ".join(f"{k}: {_short(v)}" for k, v in shown.items() if k != "step")
    view.events.append(Event(at, "host", event.event.replace("_", " "), text, stage))
    return stage


def _close_stages(stages: list[_Stage], view: EpisodeView) -> None:
    for k, s in enumerate(stages):
        if s.end is None:
            s.end = stages[k + 1].start if k + 1 < len(stages) else view.last_step
    view.stages = [{"name": s.name, "from": s.start, "to": s.end, "ended_by": s.ended_by}
                   for s in stages]


def _frame(camera: _Camera) -> fr.Frame:
    def png(image: CompressedImage | None) -> np.ndarray | None:
        if image is None:
            return None
        try:
            return fr.decode_png(image.image_bytes())
        except ValueError:
            return None

    metres = camera.depth.metres() if camera.depth is not None else None
    depth = fr.depth_picture(metres) if metres is not None else None
    return fr.Frame(step=camera.step, rgb=png(camera.rgb), depth=depth,
                    segmentation=png(camera.segmentation))


def _short(v: Any, limit: int = 160) -> str:
    text = v if isinstance(v, str) else json.dumps(v, default=str)
    return text if len(text) <= limit else text[: limit - 1] + "…"


# ------------------------------------------------------------------ the agent's own files
def _agent_log(host: Path, view: EpisodeView) -> None:
    log = host / "output" / "episode_log.jsonl"
    if not log.is_file():
        return
    lines = log.read_text(errors="replace").splitlines()
    if len(lines) > MAX_AGENT_RECORDS:
        view.problems.append(f"the agent's episode_log.jsonl has {len(lines)} records: the "
                             f"first {MAX_AGENT_RECORDS} are on the timeline")
    for line in lines[:MAX_AGENT_RECORDS]:
        try:
            rec = json.loads(line)
            step = int(rec.get("step", 0))
        except (ValueError, TypeError, AttributeError):
            continue
        data = rec.get("data")
        view.events.append(Event(step, "agent", str(rec.get("event", "record")),
                                 "" if not data else _short(data), str(rec.get("stage", ""))))


def _snapshots(host: Path, result: EpisodeResult, view: EpisodeView) -> None:
    folder = host / "snapshots"
    stages = [s for s in result.stages_reached if (folder / s).is_dir()]
    stages += sorted(p.name for p in folder.glob("*") if p.is_dir() and p.name not in stages)
    before: dict[str, Any] = {}
    for stage in stages:
        for file in sorted((folder / stage).glob("*.json")):
            try:
                doc = json.loads(file.read_text())
            except (ValueError, OSError):
                view.snapshots.append(Snapshot(stage, file.name, "(not JSON)", (), True))
                continue
            first = file.name not in before
            changes = () if first else tuple(diff(before[file.name], doc))
            before[file.name] = doc
            text = json.dumps(doc, indent=1)
            if len(text) > MAX_SNAPSHOT_CHARS:
                text = (text[:MAX_SNAPSHOT_CHARS]
                        + f"\n… {len(text) - MAX_SNAPSHOT_CHARS} more characters")
            view.snapshots.append(Snapshot(stage, file.name, text, changes, first))


def diff(old: Any, new: Any, where: str = "") -> list[str]:
    """What changed from ``old`` to ``new``, one line per changed leaf (JSON paths); lists
    of objects with an ``id`` are matched by id."""
    out: list[str] = []
    _diff(old, new, where, out)
    if len(out) > MAX_CHANGES:
        out = [*out[:MAX_CHANGES], f"… and {len(out) - MAX_CHANGES} more"]
    return out


def _keyed(items: list[Any]) -> dict[Any, Any] | None:
    if items and all(isinstance(i, dict) and "id" in i for i in items):
        return {i["id"]: i for i in items}
    return None


def _diff(old: Any, new: Any, where: str, out: list[str]) -> None:
    if isinstance(old, dict) and isinstance(new, dict):
        for k in [*old, *(k for k in new if k not in old)]:
            at = f"{where}.{k}" if where else str(k)
            if k not in new:
                out.append(f"- {at}")
            elif k not in old:
                out.append(f"+ {at}: {_short(new[k], 100)}")
            else:
                _diff(old[k], new[k], at, out)
    elif isinstance(old, list) and isinstance(new, list) and old != new:
        a, b = _keyed(old), _keyed(new)
        if a is None or b is None:
            out.append(f"~ {where}: {len(old)} → {len(new)} items" if len(old) != len(new)
                       else f"~ {where}: {_short(old, 60)} → {_short(new, 60)}")
            return
        for k in [*a, *(k for k in b if k not in a)]:
            at = f"{where}[id={k}]"
            if k not in b:
                out.append(f"- {at}")
            elif k not in a:
                out.append(f"+ {at}: {_short(b[k], 100)}")
            else:
                _diff(a[k], b[k], at, out)
    elif old != new:
        out.append(f"~ {where}: {_short(old, 60)} → {_short(new, 60)}")


def _log_tail(host: Path, result: EpisodeResult, view: EpisodeView) -> None:
    text = ""
    log = host / "agent.log"
    if log.is_file():
        text = log.read_text(errors="replace")
    elif result.failure is not None:
        text = result.failure.log_tail
    view.log_tail = "\n".join(text.rstrip().splitlines()[-LOG_TAIL_LINES:])


# ------------------------------------------------------------------- the track's hooks
def _plugin(track: str, view: EpisodeView) -> TrackPlugin | None:
    try:
        return load_track(track)
    except Exception as e:  # noqa: BLE001 - a page without the track's parts is a page
        view.problems.append(f"no map, pictures or truth: {e}")
        return None


def _map(plugin: TrackPlugin, episode: RecordedEpisode, view: EpisodeView) -> None:
    """The track's map under the path, and its pictures of spans of steps."""
    try:
        shown = plugin.episode_map(episode)
        if shown is not None:
            height, width = shown.rgb.shape[:2]
            view.map_image = fr.data_uri(fr.encode_png(np.asarray(shown.rgb, np.uint8)))
            view.map_frame = {"ox": shown.ox, "oy": shown.oy, "scale": shown.scale,
                              "width": width, "height": height}
            view.map_caption = shown.caption
        view.pictures = [{"from": p.first_step, "to": p.last_step, "caption": p.caption,
                          "image": fr.data_uri(p.png)}
                         for p in plugin.step_pictures(episode)]
    except Exception as e:  # noqa: BLE001 - a page without its map is still a page
        view.problems.append(f"no map: {type(e).__name__}: {e}")


def _truth(plugin: TrackPlugin, episode: RecordedEpisode, view: EpisodeView) -> None:
    """The track's comparison of the agent's model with the hidden truth."""
    try:
        report = plugin.truth(episode)
    except SchemaError as e:
        view.problems.append(f"no model-vs-truth comparison: {e.summary}")
        return
    except Exception as e:  # noqa: BLE001 - the rest of the page stands without it
        view.problems.append(f"no model-vs-truth comparison: {type(e).__name__}: {e}")
        return
    if report is not None:
        view.truth, view.truth_of, view.truth_note = list(report.lines), report.of, report.note


def _track_picture(plugin: TrackPlugin, folder: Path, view: EpisodeView) -> None:
    """The track's own picture of the episode (organizers: it marks the hidden goals)."""
    import tempfile

    try:
        with tempfile.TemporaryDirectory() as tmp:
            out = plugin.picture(folder, Path(tmp) / "picture.png")
            view.picture = fr.data_uri(out.read_bytes())
    except Exception as e:  # noqa: BLE001 - tracks without pictures, broken logs
        view.problems.append(f"no track picture: {e}")
