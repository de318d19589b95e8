"""The records of an episode's MCAP log (``simhost.host._mcap`` writes it), typed, read back.

One model per record kind, so that every reader (the episode viewer, the audit, the
replay, the tracks' pictures) reads attributes, never string keys:

========================== ==================================================================
topic                      body of each ``Record``
========================== ==================================================================
``/eagc/scenario``         ``ScenarioRecord``: the hidden scenario and episode metadata
``/eagc/request``          ``RequestRecord``: one of ``HelloRequest``, ``ResetRequest``,
                           ``StepRequest`` (the checked action), ``AnswerRequest``,
                           ``EndStageRequest`` (the payload), by ``kind``
``/eagc/reply``            ``schemas.Reply``: the protocol's reply models, tensors left out
``/eagc/observation``      ``SmallTensors``: the observation tensors of ≤ 256 values
``/eagc/event``            ``HostEvent``: a model per event the host and the tracks record
                           (stages, the episode's end, protocol errors, the controlled
                           exception, Track 2's attempts, …), by ``event``; any other event
                           is an ``OtherEvent`` holding its fields, never an error
``/eagc/state_hash``       ``StateHash``
``/eagc/state``            ``FullState`` (raw bytes)
``/eagc/file/<stage>/<f>`` ``OutputFile`` (raw bytes)
``/eagc/score``            ``schemas.EpisodeResult``
``/tf``                    ``FrameTransforms`` (Foxglove's schema)
``/trajectory/<frame>``    ``PosesInFrame`` (Foxglove's schema)
``/camera/rgb``,           ``CompressedImage`` (Foxglove's schema, PNG)
``/camera/segmentation``
``/camera/depth``          ``RawImage`` (Foxglove's schema, ``32FC1`` metres)
========================== ==================================================================

``read_records(path)`` yields each message as a ``Record`` (topic, log time, body); a
topic not listed is skipped. A record that is not JSON, or not the shape its topic has,
raises ``McapRecordError`` with one line that names the file, the topic, the time (from
the first message read) and the field (or, given ``on_problem``, is reported to it and
skipped), as does a file that is not a readable MCAP log. Records keep fields they do not
declare (``extra``), so that a log written by a later version still reads.
"""

from __future__ import annotations

import base64
import json
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    PrivateAttr,
    Tag,
    TypeAdapter,
    ValidationError,
    model_validator,
)

from schemas import (
    EndReason,
    EpisodeResult,
    ErrorReply,
    HelloReply,
    ObservationReply,
    Reply,
    describe,
)
from simhost._errors import SimHostError
from simhost.host._episode import StageEnd


class McapRecordError(SimHostError, ValueError):
    """Raised when an episode's MCAP log cannot be read, or holds a record that is not one
    of ours (not JSON, or not the shape its topic has)."""


class _Record(BaseModel):
    model_config = ConfigDict(frozen=True, extra="allow")


# --------------------------------------------------------------------------- scenario
class ScenarioRecord(_Record):
    """``/eagc/scenario``: the hidden scenario and the episode's metadata (written once,
    first, by the episode worker)."""

    episode: str
    track: str
    split: str
    seed: int
    image: str = ""
    """The agent's image (or command, for a local process)."""
    params: dict[str, Any] = Field(default_factory=dict)
    """The track's hidden scenario (its own model validates it: ``Track1Scenario``, …)."""
    limits: dict[str, Any] | None = None
    """``schemas.Limits`` as dumped, kept as written so that old logs outlive the model."""
    cpus: dict[str, Any] | None = None
    """Where the episode was placed (``None``: not pinned)."""


# --------------------------------------------------------------------------- requests
class HelloRequest(_Record):
    """A hello the host applied."""

    kind: Literal["hello"]
    stage: str | None = None
    agent: str = ""
    protocol: str = ""


class ResetRequest(_Record):
    """A reset the host applied (before the first stage: ``stage`` None)."""

    kind: Literal["reset"]
    stage: str | None = None


class StepRequest(_Record):
    """A step the host applied in ``stage``, with the checked action (field → value)."""

    kind: Literal["step"]
    stage: str
    action: dict[str, Any]


class AnswerRequest(_Record):
    """Answers the host applied in ``stage`` (query id → answer)."""

    kind: Literal["answer"]
    stage: str
    answers: dict[str, Any]


class EndStageRequest(_Record):
    """An end of ``stage`` the agent asked for, with its payload."""

    kind: Literal["end_stage"]
    stage: str
    payload: dict[str, Any] = Field(default_factory=dict)


RequestRecord = Annotated[HelloRequest | ResetRequest | StepRequest | AnswerRequest
                          | EndStageRequest, Field(discriminator="kind")]


# ---------------------------------------------------------------------------- events
class _Event(_Record):
    event: str
    _order: tuple[str, ...] = PrivateAttr(default=())

    @model_validator(mode="wrap")
    @classmethod
    def _keep_order(cls, data: Any, handler: Callable[[Any], Any]) -> Any:
        out = handler(data)
        if isinstance(data, dict):
            out._order = tuple(data)
        return out

    def fields(self) -> dict[str, Any]:
        """Every field the event was written with but ``event``, in the order written
        (JSON values)."""
        dumped = self.model_dump(mode="json", exclude_unset=True, exclude={"event"})
        order = [k for k in self._order if k in dumped]
        return {k: dumped[k] for k in [*order, *(k for k in dumped if k not in order)]}

    @property
    def at_step(self) -> int | None:
        """The step the event names, when it names one as an integer."""
        step = getattr(self, "step", None)
        return step if isinstance(step, int) else None


class HostOpenEvent(_Event):
    """The host opened the episode's session."""

    event: Literal["host_open"]
    episode: str


class InternalErrorEvent(_Event):
    """A host or track bug ended the episode."""

    event: Literal["internal_error"]
    error: str


class ProtocolErrorEvent(_Event):
    """A request the host refused (``schemas.ErrorReply``'s code and message)."""

    event: Literal["protocol_error"]
    code: str
    message: str
    fatal: bool = False


class StageStartEvent(_Event):
    """A stage began."""

    event: Literal["stage_start"]
    stage: str
    index: int


class StageEndEvent(_Event):
    """A stage ended: by the agent, its time or its steps running out, or the episode
    stopping."""

    event: Literal["stage_end"]
    stage: str
    ended_by: StageEnd


class EpisodeEndEvent(_Event):
    """The episode ended."""

    event: Literal["episode_end"]
    reason: EndReason


class ExceptionEvent(_Event):
    """The controlled exception was applied (Track 1: ``ExceptionRecord``'s fields; sanity:
    the target moved from ``at`` to ``to``)."""

    event: Literal["exception"]
    type: str
    goal: int | None = None
    subject: int | None = None
    """The door, object, container or tool it changed."""
    step: int | None = None
    """The step at which it was applied."""
    pose: tuple[float, float] | None = None
    """Where the robot was then (x, y)."""
    details: dict[str, Any] | None = None
    effect_step: int | None = None
    at: list[float] | None = None
    to: list[float] | None = None


class ExceptionArmedEvent(_Event):
    """Track 1: the exception waits for its trigger, on this door, container or item."""

    event: Literal["exception_armed"]
    type: str
    door: int | None = None
    container: int | None = None
    subject: int | None = None
    route_doors: list[int] | None = None

    @property
    def armed_on(self) -> int | None:
        """What it will change: the door, the container, or the item."""
        return next((x for x in (self.door, self.container, self.subject) if x is not None),
                    None)


class ExceptionObservableEvent(_Event):
    """Track 1: the first step at which the agent could observe the exception."""

    event: Literal["exception_observable"]
    type: str | None = None
    step: int


class ExceptionSkippedEvent(_Event):
    """Track 1: the planned exception could not be applied, and why."""

    event: Literal["exception_skipped"]
    type: str
    reason: str


class AttemptEndEvent(_Event):
    """Track 2: an attempt on the hidden instance ended (``AttemptRecord``'s fields)."""

    event: Literal["attempt_end"]
    index: int
    steps: int = 0
    success: bool = False


class OtherEvent(_Event):
    """Any other event (a track's own: ``plan``, ``subgoal``, ``task_satisfied``, …): its
    fields are kept as written (``fields()``)."""


_KNOWN = frozenset({"host_open", "internal_error", "protocol_error", "stage_start",
                    "stage_end", "episode_end", "exception", "exception_armed",
                    "exception_observable", "exception_skipped", "attempt_end"})


def _event_tag(value: Any) -> str:
    name = value.get("event") if isinstance(value, dict) else getattr(value, "event", None)
    return name if isinstance(name, str) and name in _KNOWN else "other"


HostEventModel = (HostOpenEvent | InternalErrorEvent | ProtocolErrorEvent | StageStartEvent
                  | StageEndEvent | EpisodeEndEvent | ExceptionEvent | ExceptionArmedEvent
                  | ExceptionObservableEvent | ExceptionSkippedEvent | AttemptEndEvent
                  | OtherEvent)
"""Any of the event models (``HostEvent`` is the same union, discriminated for pydantic)."""
HostEvent = Annotated[
    Annotated[HostOpenEvent, Tag("host_open")]
    | Annotated[InternalErrorEvent, Tag("internal_error")]
    | Annotated[ProtocolErrorEvent, Tag("protocol_error")]
    | Annotated[StageStartEvent, Tag("stage_start")]
    | Annotated[StageEndEvent, Tag("stage_end")]
    | Annotated[EpisodeEndEvent, Tag("episode_end")]
    | Annotated[ExceptionEvent, Tag("exception")]
    | Annotated[ExceptionArmedEvent, Tag("exception_armed")]
    | Annotated[ExceptionObservableEvent, Tag("exception_observable")]
    | Annotated[ExceptionSkippedEvent, Tag("exception_skipped")]
    | Annotated[AttemptEndEvent, Tag("attempt_end")] | Annotated[OtherEvent, Tag("other")],
    Discriminator(_event_tag),
]
_EVENT: TypeAdapter[HostEventModel] = TypeAdapter(HostEvent)


def parse_event(data: Any) -> HostEventModel:
    """One ``/eagc/event`` record (a dict) as its model; an unknown event is an
    ``OtherEvent``. Raises ``pydantic.ValidationError`` when a known event lacks a field."""
    return _EVENT.validate_python(data)


# ---------------------------------------------------------------------- steps, tensors
class StateHash(_Record):
    """``/eagc/state_hash``: the simulator state's hash after a step."""

    step: int
    hash: str


@dataclass(frozen=True)
class FullState:
    """``/eagc/state``: the full simulator state (raw bytes, every N steps)."""

    data: bytes


@dataclass(frozen=True)
class OutputFile:
    """``/eagc/file/<stage>/<name>``: an agent's ``/output`` file as a stage ended."""

    stage: str
    name: str
    data: bytes


@dataclass(frozen=True)
class SmallTensors:
    """``/eagc/observation``: the small observation tensors of a reply (name → nested
    lists of numbers)."""

    values: dict[str, Any]

    def vector(self, name: str) -> list[float] | None:
        """Tensor ``name`` flattened, as floats (None when the reply had none)."""
        value = self.values.get(name)
        if value is None:
            return None
        return [float(x) for x in np.asarray(value, dtype=np.float64).ravel()]


# ------------------------------------------------------------------- Foxglove's schemas
class Time(_Record):
    sec: int
    nsec: int


class Vector3(_Record):
    x: float
    y: float
    z: float


class Quaternion(_Record):
    x: float
    y: float
    z: float
    w: float


class PoseJson(_Record):
    """``foxglove.Pose``."""

    position: Vector3
    orientation: Quaternion


class FrameTransform(_Record):
    """``foxglove.FrameTransform``: where ``child_frame_id`` is in ``parent_frame_id``."""

    timestamp: Time
    parent_frame_id: str
    child_frame_id: str
    translation: Vector3
    rotation: Quaternion


class FrameTransforms(_Record):
    """``/tf``: the track's poses after a step (``foxglove.FrameTransforms``)."""

    transforms: list[FrameTransform] = Field(default_factory=list)

    def of(self, frame: str) -> FrameTransform | None:
        """The transform of child frame ``frame`` (None: not in this message)."""
        return next((t for t in self.transforms if t.child_frame_id == frame), None)


class PosesInFrame(_Record):
    """``/trajectory/<frame>``: a frame's whole path (``foxglove.PosesInFrame``)."""

    timestamp: Time
    frame_id: str
    poses: list[PoseJson] = Field(default_factory=list)


class CompressedImage(_Record):
    """``/camera/rgb``, ``/camera/segmentation`` (``foxglove.CompressedImage``)."""

    timestamp: Time
    frame_id: str
    format: str
    data: str
    """The image file, base64."""

    def image_bytes(self) -> bytes:
        """The image file (PNG)."""
        return base64.b64decode(self.data)


class RawImage(_Record):
    """``/camera/depth`` (``foxglove.RawImage``)."""

    timestamp: Time
    frame_id: str
    width: int
    height: int
    encoding: str
    step: int
    data: str
    """Rows of pixels, base64."""

    def metres(self) -> np.ndarray | None:
        """A ``32FC1`` image as height × width float32 metres (None for another encoding)."""
        if self.encoding != "32FC1":
            return None
        values = np.frombuffer(base64.b64decode(self.data), "<f4")
        return values.reshape(self.height, self.width)


# ------------------------------------------------------------------------------ reading
Body = (ScenarioRecord | HelloRequest | ResetRequest | StepRequest | AnswerRequest
        | EndStageRequest | HelloReply | ObservationReply | ErrorReply | SmallTensors
        | HostEventModel | StateHash | FullState | OutputFile | EpisodeResult
        | FrameTransforms | PosesInFrame | CompressedImage | RawImage)
"""What a ``Record`` holds (by topic: module doc)."""


@dataclass(frozen=True)
class Record:
    """One message of the log: its topic, its log time (ns) and its typed body."""

    topic: str
    log_time: int
    body: Body


_SCENARIO = TypeAdapter(ScenarioRecord)
_JSON: dict[str, TypeAdapter[Any]] = {
    "/eagc/scenario": _SCENARIO,
    "/eagc/request": TypeAdapter(RequestRecord),
    "/eagc/reply": TypeAdapter(Reply),
    "/eagc/event": _EVENT,
    "/eagc/state_hash": TypeAdapter(StateHash),
    "/eagc/score": TypeAdapter(EpisodeResult),
    "/tf": TypeAdapter(FrameTransforms),
    "/camera/rgb": TypeAdapter(CompressedImage),
    "/camera/segmentation": TypeAdapter(CompressedImage),
    "/camera/depth": TypeAdapter(RawImage),
}
_TENSORS = TypeAdapter(dict[str, Any])
TOPICS = (*_JSON, "/eagc/observation", "/eagc/state", "/eagc/file/<stage>/<name>",
          "/trajectory/<frame>")
"""The topics read (the last two are prefixes)."""


def _problem(e: ValidationError) -> str:
    first, *rest = describe(e)
    return first.removeprefix("(top level): ") + (f" (and {len(rest)} more)" if rest else "")


def _decode(topic: str, data: bytes) -> Any:
    """The body of one message, or None for a topic this module does not read."""
    if topic == "/eagc/state":
        return FullState(data)
    if topic.startswith("/eagc/file/"):
        stage, _, name = topic[len("/eagc/file/"):].partition("/")
        return OutputFile(stage, name, data)
    adapter = _JSON.get(topic)
    if adapter is None and not (topic == "/eagc/observation"
                                or topic.startswith("/trajectory/")):
        return None
    doc = json.loads(data)
    if adapter is not None:
        return adapter.validate_python(doc)
    if topic == "/eagc/observation":
        return SmallTensors(_TENSORS.validate_python(doc))
    return PosesInFrame.model_validate(doc)


def read_records(path: Path | str, topics: Iterable[str] | None = None, *,
                 log_time_order: bool = True,
                 on_problem: Callable[[McapRecordError], None] | None = None,
                 ) -> Iterator[Record]:
    """Every message of the episode log at ``path`` (of ``topics`` only, exact names, when
    given), typed (module doc).

    Args:
        path: an ``episode.mcap``.
        topics: the topics wanted (None: all).
        log_time_order: in log-time order (else in the file's order, faster).
        on_problem: called with a record that does not read, which is then skipped
            (None: it raises).

    Raises:
        McapRecordError: the file is not a readable MCAP log, or (without ``on_problem``)
            a record is not one of ours.
    """
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    path = Path(path)
    wanted = None if topics is None else list(topics)
    start: int | None = None  # the log's first time: the recorder's 0 s
    try:
        with path.open("rb") as f:
            messages = make_reader(f).iter_messages(topics=wanted,
                                                    log_time_order=log_time_order)
            for _, channel, message in messages:
                topic, t = channel.topic, message.log_time
                start = t if start is None else min(start, t)
                try:
                    body = _decode(topic, message.data)
                except (ValueError, TypeError) as e:  # not JSON, or not the model
                    why = _problem(e) if isinstance(e, ValidationError) else (
                        f"not JSON ({str(e).splitlines()[0] if str(e) else type(e).__name__})")
                    problem = McapRecordError(
                        f"{path}: the {topic} record at {(t - start) / 1e9:.3f} s is not "
                        f"one of eagc's: {why}")
                    if on_problem is None:
                        raise problem from None
                    on_problem(problem)
                    continue
                if body is not None:
                    yield Record(topic, t, body)
    except McapRecordError:
        raise
    except (McapError, EOFError, OSError, RuntimeError, ValueError) as e:
        # a file cut short (an episode killed while writing), or not MCAP at all
        why = str(e).splitlines()[0] if str(e) else type(e).__name__
        problem = McapRecordError(f"{path}: not a readable MCAP log ({why})")
        if on_problem is None:
            raise problem from None
        on_problem(problem)


def read_scenario(path: Path | str) -> ScenarioRecord | None:
    """The log's ``/eagc/scenario`` record (None when it has none: not an eagc episode
    log). Raises ``McapRecordError`` as ``read_records`` does."""
    for record in read_records(path, ["/eagc/scenario"], log_time_order=False):
        assert isinstance(record.body, ScenarioRecord)
        return record.body
    return None
