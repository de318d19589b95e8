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

    name: str = Field(min_length=1, max_length=64)
    dtype: DType
    shape: tuple[Annotated[int, Field(ge=0)], ...] = Field(max_length=8)
    offset: int = Field(ge=0, description="Byte offset from the start of the tensor block.")
    nbytes: int = Field(ge=0)


class FieldSpec(_Frozen):
    """One named entry of an observation or action: what it holds and what is allowed."""

    name: str
    dtype: DType | Literal["str", "json"] = Field(
        description="A tensor dtype; 'str' for text; 'json' for any JSON value (observations)."
    )
    shape: tuple[int, ...] = ()
    low: float | None = Field(default=None, description="Inclusive lower bound (numbers).")
    high: float | None = Field(default=None, description="Inclusive upper bound (numbers).")
    choices: tuple[str, ...] | None = Field(
        default=None,
        description="Named values: an integer field accepts the index or the name.",
    )
    tensor: bool = Field(
        default=False, description="True when the value travels as a binary tensor."
    )
    description: str = ""


class StageInfo(_Frozen):
    """A stage of the episode as announced to the agent at hello."""

    name: str
    budget_s: float = Field(gt=0, description="Wall-clock budget, measured by the host.")
    max_steps: int | None = Field(default=None, description="Step cap, when there is one.")
    allows_motion: bool = True
    description: str = ""


class EndReason(StrEnum):
    """Why an episode ended: one vocabulary for the host, the worker and the track plugins.

    A ``StrEnum``: each member equals its plain string (``EndReason.BUDGET == "budget"``).
    """

    #: The agent ended the last stage, or the track declared the task done.
    COMPLETED = "completed"
    #: Track 2: an attempt succeeded (the episode ends at the first success).
    SUCCESS = "success"
    #: Track 2: the last attempt ended without success.
    ATTEMPTS_USED = "attempts_used"
    #: The last stage's wall-clock budget ran out.
    BUDGET = "budget"
    #: The last stage's step cap was reached.
    STEPS = "steps"
    #: The evaluator stopped the episode (e.g. the agent's container exited).
    STOPPED = "stopped"
    #: The agent's liveliness token went (its process or session ended).
    AGENT_LOST = "agent_lost"
    #: The agent did not say hello and reset within the startup budget.
    STARTUP_TIMEOUT = "startup_timeout"
    #: Too many protocol errors, or a protocol the host does not speak.
    PROTOCOL_VIOLATION = "protocol_violation"
    #: A host or track bug (an infrastructure failure, not the agent's).
    INTERNAL_ERROR = "internal_error"
    #: The episode never began.
    NOT_STARTED = "not_started"


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
    tensors: tuple[TensorMeta, ...] = ()


class Hello(_Request):
    """Opens the episode; the reply carries the specs of observations and actions."""

    kind: Literal["hello"] = "hello"
    protocol: str = PROTOCOL_VERSION
    agent: str = Field(default="", max_length=128, description="Free-form name and version.")


class Reset(_Request):
    """Starts the first stage; the reply carries the first observation."""

    kind: Literal["reset"] = "reset"


class Step(_Request):
    """Applies one action. Array fields may come in ``action`` or as tensors of that name."""

    kind: Literal["step"] = "step"
    action: dict[str, Any] = Field(default_factory=dict)


class Answer(_Request):
    """Answers the host's queries about the agent's model (keyed by query id)."""

    kind: Literal["answer"] = "answer"
    answers: dict[str, Any]


class EndStage(_Request):
    """Ends the current stage early; ``payload`` carries e.g. Track 1's plan."""

    kind: Literal["end_stage"] = "end_stage"
    payload: dict[str, Any] = Field(default_factory=dict)


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
    ]
    data: dict[str, Any] = Field(default_factory=dict)


class ActionResult(_Frozen):
    """What became of the action in the request."""

    applied: bool
    ok: bool
    reason: str = ""


class _Reply(_Frozen):
    seq: int = Field(ge=0)
    id: RequestId | None = Field(
        default=None,
        description="The id of the request this answers, when it carried one (also on an "
        "error reply, whenever the request's header could be read).",
    )
    tensors: tuple[TensorMeta, ...] = ()


class HelloReply(_Reply):
    """The reply to hello: the episode's specs and stages, sent once."""

    kind: Literal["hello"] = "hello"
    protocol: str = PROTOCOL_VERSION
    episode: str = Field(description="The opaque episode id.")
    track: str
    observation_spec: tuple[FieldSpec, ...]
    action_spec: tuple[FieldSpec, ...]
    stages: tuple[StageInfo, ...]
    max_request_bytes: int = Field(description="Longest request the host reads (bytes).")
    startup_budget_s: float = Field(description="Time left to send reset after this reply.")


class ObservationReply(_Reply):
    """The reply to reset, step, answer and end_stage."""

    kind: Literal["observation"] = "observation"
    stage: str
    stage_index: int
    time_left_s: float
    steps_left: int | None = None
    observation: dict[str, Any] = Field(
        default_factory=dict, description="Non-tensor observation entries (JSON)."
    )
    action: ActionResult | None = None
    messages: tuple[HostMessage, ...] = ()
    episode_over: bool = False
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


class ErrorReply(_Reply):
    """A request that could not be served. Nothing changed unless ``fatal``."""

    kind: Literal["error"] = "error"
    code: ErrorCode
    message: str
    fatal: bool = False


Reply = Annotated[HelloReply | ObservationReply | ErrorReply, Field(discriminator="kind")]
