"""Protocol v1 messages between a team's agent and the sim host.

Every message travels as one Zenoh payload: the 4-byte magic ``EGC1``, a u32 little-endian
header length, a JSON header validated by one of the models below (discriminated on
``kind``) and space-padded to a multiple of 8 bytes, then the raw bytes of the tensors the
header lists (row-major, little-endian, in order, each at the next multiple of 8). The byte
layout is specified in ``schemas/PROTOCOL.md`` and implemented in ``simhost._wire``.

Sequence numbers belong to the host. The agent sends ``seq`` equal to the ``seq`` of the
last reply it received (0 before ``hello``). A reply that moves the episode forward carries
``seq + 1``; an error reply carries the host's current ``seq`` and changes nothing, so the
agent can resynchronise and retry. A request may carry an ``id`` of the agent's choosing;
the reply to it echoes the ``id``, so that an agent matches replies to requests.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

PROTOCOL_VERSION = "eagc/v1"

DType = Literal["float32", "float64", "int32", "int64", "uint8", "uint16", "bool"]


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class TensorMeta(_Frozen):
    """Where one binary tensor of a message lies after the JSON header."""

    name: str = Field(min_length=1, max_length=64, description="Unique in the message.")
    dtype: DType = Field(description="Element type; bytes are little-endian.")
    shape: tuple[Annotated[int, Field(ge=0)], ...] = Field(
        max_length=8, description="Dimensions, row-major; [] for a scalar."
    )
    offset: int = Field(
        ge=0,
        description="Byte offset from the start of the tensor block: 0 for the first tensor, "
        "then where the previous tensor's padding ends (a multiple of 8).",
    )
    nbytes: int = Field(ge=0, description="The product of the shape times the dtype's size.")


class FieldSpec(_Frozen):
    """One named entry of an observation or action: what it holds and what is allowed."""

    name: str = Field(description="The key in the observation or action.")
    dtype: DType | Literal["str", "json"] = Field(
        description="A tensor dtype; 'str' for text; 'json' for any JSON value (observations)."
    )
    shape: tuple[int, ...] = Field(default=(), description="[] for a scalar.")
    low: float | None = Field(default=None, description="Inclusive lower bound (numbers).")
    high: float | None = Field(default=None, description="Inclusive upper bound (numbers).")
    choices: tuple[str, ...] | None = Field(
        default=None,
        description="Named values: an integer field accepts the index or the name.",
    )
    tensor: bool = Field(
        default=False,
        description="True when the value travels as a binary tensor (else in the JSON "
        "observation).",
    )
    description: str = Field(default="", description="What it means: units, frame, padding.")


class StageInfo(_Frozen):
    """A stage of the episode as announced to the agent at hello."""

    name: str
    budget_s: float = Field(
        gt=0, description="Wall-clock budget (s), measured by the host, as scaled for this "
        "campaign."
    )
    max_steps: int | None = Field(default=None, description="Step cap, when there is one.")
    allows_motion: bool = Field(
        default=True, description="False when nothing may move (motion is refused)."
    )
    description: str = ""


class EndReason(StrEnum):
    """Why an episode ended: one vocabulary for the host, the worker and the track plugins.

    A ``StrEnum``: each member equals its plain string (``EndReason.BUDGET == "budget"``);
    ``.description`` says what it means.
    """

    description: str

    def __new__(cls, value: str, description: str = "") -> EndReason:
        member = str.__new__(cls, value)
        member._value_ = value
        member.description = description
        return member

    COMPLETED = "completed", "The agent ended the last stage, or the track declared the task done."
    SUCCESS = "success", "Track 2: an attempt succeeded (the episode ends at the first success)."
    ATTEMPTS_USED = "attempts_used", "Track 2: the last attempt ended without success."
    BUDGET = "budget", "The last stage's wall-clock budget ran out."
    STEPS = "steps", "The last stage's step cap was reached."
    STOPPED = "stopped", "The evaluator stopped the episode (e.g. the agent's process exited)."
    AGENT_LOST = "agent_lost", "The agent's liveliness token went (its process or session ended)."
    STARTUP_TIMEOUT = "startup_timeout", (
        "The agent did not say hello and reset within the startup budget.")
    PROTOCOL_VIOLATION = "protocol_violation", (
        "Too many protocol errors, or a hello with a protocol the host does not speak.")
    INTERNAL_ERROR = "internal_error", (
        "A host or track bug: an infrastructure failure, not the agent's.")
    NOT_STARTED = "not_started", "The episode never began."


RequestId = Annotated[int, Field(ge=0, le=2**53 - 1)]


# ----------------------------------------------------------------------------- requests
class _Request(_Frozen):
    seq: int = Field(ge=0, description="The seq of the last reply received (0 before hello).")
    id: RequestId | None = Field(
        default=None,
        description="Optional, the agent's own: echoed in the reply to this request, so that "
        "the agent can match replies to requests (e.g. ignore a second reply to a resent "
        "hello). A resent request keeps its id.",
    )
    tensors: tuple[TensorMeta, ...] = Field(
        default=(), description="The tensors after the header, in order."
    )


class Hello(_Request):
    """Opens the episode; the reply carries the specs of observations and actions."""

    kind: Literal["hello"] = "hello"
    protocol: str = Field(
        default=PROTOCOL_VERSION, description="Must be \"eagc/v1\": another ends the episode."
    )
    agent: str = Field(default="", max_length=128, description="Free-form name and version.")


class Reset(_Request):
    """Starts the first stage; the reply carries the first observation."""

    kind: Literal["reset"] = "reset"


class Step(_Request):
    """Applies one action. Array fields may come in ``action`` or as tensors of that name."""

    kind: Literal["step"] = "step"
    action: dict[str, Any] = Field(
        default_factory=dict,
        description="The action's fields by name (see the action spec); array fields may "
        "come as tensors of the same name instead.",
    )


class Answer(_Request):
    """Answers the host's queries about the agent's model (keyed by query id)."""

    kind: Literal["answer"] = "answer"
    answers: dict[str, Any] = Field(description="Query id → answer.")


class EndStage(_Request):
    """Ends the current stage early; ``payload`` carries e.g. Track 1's plan."""

    kind: Literal["end_stage"] = "end_stage"
    payload: dict[str, Any] = Field(
        default_factory=dict, description="What the track takes at the stage end (a plan)."
    )


Request = Annotated[Hello | Reset | Step | Answer | EndStage, Field(discriminator="kind")]


# ------------------------------------------------------------------------------ replies
class HostMessage(_Frozen):
    """Something the host tells the agent besides the observation."""

    type: Literal[
        "stage_started",
        "instruction",
        "queries",
        "demonstration",
        "attempt_result",
        "exception",
        "notice",
    ] = Field(description="What kind of message; each track's page says which it sends "
              "(`exception` is reserved: no track sends it, a controlled exception shows "
              "only through its effects).")
    data: dict[str, Any] = Field(default_factory=dict, description="Its content.")


class ActionResult(_Frozen):
    """What became of the action in the request."""

    applied: bool = Field(description="The action reached the world.")
    ok: bool = Field(description="The world did it (false: refused, an invalid action).")
    reason: str = Field(default="", description="Why it was not applied or not ok.")


class _Reply(_Frozen):
    seq: int = Field(ge=0, description="The host's sequence number: send it in your next "
                     "request.")
    id: RequestId | None = Field(
        default=None,
        description="The id of the request this answers, when it carried one (also on an "
        "error reply, whenever the request's header could be read).",
    )
    tensors: tuple[TensorMeta, ...] = Field(
        default=(), description="The tensors after the header, in order."
    )


class HelloReply(_Reply):
    """The reply to hello (and, alike, to each resent copy of it): the episode's specs."""

    kind: Literal["hello"] = "hello"
    protocol: str = PROTOCOL_VERSION
    episode: str = Field(description="The opaque episode id.")
    track: str = Field(description="The track's name, e.g. \"track1\".")
    observation_spec: tuple[FieldSpec, ...] = Field(description="Every observation entry.")
    action_spec: tuple[FieldSpec, ...] = Field(description="Every action field.")
    stages: tuple[StageInfo, ...] = Field(description="The stages, in order.")
    max_request_bytes: int = Field(description="Longest request the host reads (bytes).")
    startup_budget_s: float = Field(description="Time left to send reset after this reply.")


class ObservationReply(_Reply):
    """The reply to reset, step, answer and end_stage."""

    kind: Literal["observation"] = "observation"
    stage: str = Field(description="The current stage (the next one, if this request ended "
                       "a stage).")
    stage_index: int = Field(description="Its index in the hello reply's stages.")
    time_left_s: float = Field(description="Wall-clock time left in the stage (s).")
    steps_left: int | None = Field(default=None, description="Steps left in the stage, when "
                                   "it has a cap.")
    observation: dict[str, Any] = Field(
        default_factory=dict, description="Non-tensor observation entries (JSON)."
    )
    action: ActionResult | None = Field(default=None, description="What became of the "
                                        "request's action (step requests).")
    messages: tuple[HostMessage, ...] = Field(default=(), description="What the host tells "
                                              "the agent, in order.")
    episode_over: bool = Field(default=False, description="True in the last reply.")
    end_reason: EndReason | None = Field(
        default=None, description="Why the episode ended, once ``episode_over``."
    )


ErrorCode = Literal[
    "malformed",
    "oversized",
    "stale",
    "bad_order",
    "invalid_action",
    "not_allowed",
    "episode_over",
    "internal",
]

#: What each error code means (the protocol page's table is generated from this).
ERROR_CODES: dict[ErrorCode, str] = {
    "malformed": "The request's framing or header is not as specified (the message names the "
    "problem), or a hello asks for another protocol (fatal).",
    "oversized": "The request is longer than the hello's max_request_bytes.",
    "stale": "seq is not the seq of the host's last reply (a duplicate, or a request sent "
    "before the previous reply came).",
    "bad_order": "Not allowed now: anything before hello, anything but hello before reset, "
    "a second hello or reset.",
    "invalid_action": "The action does not match the action spec (unknown field, dtype, "
    "shape, bounds, NaN/Inf); it is counted as an invalid action.",
    "not_allowed": "Reserved: a request the track refuses in the current stage (no track "
    "sends it today).",
    "episode_over": "The episode has ended; every later request gets this reply (fatal).",
    "internal": "The host failed (not the agent's fault); the episode ends (fatal).",
}


class ErrorReply(_Reply):
    """A request that could not be served. Nothing changed unless ``fatal``."""

    kind: Literal["error"] = "error"
    code: ErrorCode = Field(description="See the error codes.")
    message: str = Field(description="What was wrong, for a person.")
    fatal: bool = Field(default=False, description="True when the episode is over for the "
                        "agent.")


Reply = Annotated[HelloReply | ObservationReply | ErrorReply, Field(discriminator="kind")]
