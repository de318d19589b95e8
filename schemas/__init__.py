"""Pydantic models of everything eagc reads or writes: the models are the schema.

Light on purpose: imports only pydantic, so that a team's container can use it.
JSON Schema files generated from these models live in ``schemas/json/`` (``python -m schemas``
regenerates them; a test fails on drift).
"""

from schemas._campaign import CampaignSpec, Limits, Split, Submission
from schemas._errors import SchemaError
from schemas._files import (
    TASK_MODEL_VERSION,
    WORLD_MODEL_VERSION,
    Affordance,
    Connection,
    ContainerState,
    DoorState,
    LogRecord,
    NamedItem,
    ObjectEntry,
    Precondition,
    Room,
    TaskModel,
    WorldModel,
)
from schemas._io import load_json, parse_json, parse_jsonl
from schemas._protocol import (
    PROTOCOL_VERSION,
    ActionResult,
    Answer,
    EndStage,
    ErrorReply,
    FieldSpec,
    Hello,
    HelloReply,
    HostMessage,
    ObservationReply,
    Reply,
    Request,
    Reset,
    StageInfo,
    Step,
    TensorMeta,
)
from schemas._result import (
    ContainerExit,
    EpisodeResult,
    EpisodeStats,
    EpisodeStatus,
    FailureReport,
    FileCheck,
    ScoreCard,
)

__all__ = [
    "PROTOCOL_VERSION",
    "TASK_MODEL_VERSION",
    "WORLD_MODEL_VERSION",
    "ActionResult",
    "Affordance",
    "Answer",
    "CampaignSpec",
    "Connection",
    "ContainerExit",
    "ContainerState",
    "DoorState",
    "EndStage",
    "EpisodeResult",
    "EpisodeStats",
    "EpisodeStatus",
    "ErrorReply",
    "FailureReport",
    "FieldSpec",
    "FileCheck",
    "Hello",
    "HelloReply",
    "HostMessage",
    "Limits",
    "LogRecord",
    "NamedItem",
    "ObjectEntry",
    "ObservationReply",
    "Precondition",
    "Reply",
    "Request",
    "Reset",
    "Room",
    "SchemaError",
    "ScoreCard",
    "Split",
    "StageInfo",
    "Step",
    "Submission",
    "TaskModel",
    "TensorMeta",
    "WorldModel",
    "load_json",
    "parse_json",
    "parse_jsonl",
]
