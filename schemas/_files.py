"""The structured files an agent writes to ``/output`` (paper §II-C).

- ``world_model.json`` (Track 1, and the sanity track): the agent's queryable model of the
  world — rooms and how they connect, doors, containers, objects, tool affordances.
- ``task_model.json`` (Track 2): stages, variables, constraints, preconditions and success
  criteria inferred from the demonstration.
- ``episode_log.jsonl`` (both tracks): one record per line, in time order.

Agents should write to a temporary name and rename, so that a snapshot never sees half a file.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

WORLD_MODEL_VERSION = "eagc-world-model/v1"
TASK_MODEL_VERSION = "eagc-task-model/v1"

Id = int | str


class _File(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Room(_File):
    id: Id
    type: str | None = Field(default=None, description="kitchen, bedroom, … or null.")


class Connection(_File):
    """Two rooms that connect, through a door or an open doorway."""

    rooms: tuple[Id, Id]
    door: Id | None = None


class DoorState(_File):
    id: Id
    state: Literal["open", "closed", "locked", "unknown"]


class ContainerState(_File):
    id: Id
    type: str | None = None
    room: Id | None = None
    state: Literal["open", "closed", "unavailable", "unknown"]


class ObjectEntry(_File):
    id: Id
    category: str | None = None
    colour: str | None = None
    room: Id | None = None
    receptacle: Id | None = Field(default=None, description="Furniture or container it is on/in.")
    position: tuple[float, float] | None = Field(default=None, description="World x, y (m).")
    state: str | None = None


class Affordance(_File):
    tool: Id
    affordance: str


class WorldModel(_File):
    """``world_model.json``."""

    version: Literal["eagc-world-model/v1"] = WORLD_MODEL_VERSION
    step: int | None = Field(default=None, description="Agent step at which it was written.")
    rooms: list[Room] = Field(default_factory=list)
    connections: list[Connection] = Field(default_factory=list)
    doors: list[DoorState] = Field(default_factory=list)
    containers: list[ContainerState] = Field(default_factory=list)
    objects: list[ObjectEntry] = Field(default_factory=list)
    affordances: list[Affordance] = Field(default_factory=list)


class NamedItem(_File):
    name: str
    value: Any = None
    description: str = ""


class Precondition(_File):
    stage: str
    requires: list[str] = Field(default_factory=list)


class TaskModel(_File):
    """``task_model.json``."""

    version: Literal["eagc-task-model/v1"] = TASK_MODEL_VERSION
    family: str | None = None
    stages: list[str] = Field(default_factory=list)
    variables: list[NamedItem] = Field(default_factory=list)
    constraints: list[NamedItem] = Field(default_factory=list)
    preconditions: list[Precondition] = Field(default_factory=list)
    success_criteria: list[NamedItem] = Field(default_factory=list)


LogEvent = Literal[
    "observation",
    "action",
    "plan",
    "replan",
    "model_update",
    "exception_detected",
    "stage",
    "attempt",
    "note",
]

ExceptionType = Literal[
    "door_lock",
    "object_relocation",
    "container_unavailable",
    "tool_substitution",
    "target_moved",
]


class LogRecord(_File):
    """One line of ``episode_log.jsonl``."""

    step: int = Field(ge=0, description="Agent step count when the record was written.")
    stage: str | None = None
    event: LogEvent
    exception_type: ExceptionType | None = Field(
        default=None, description="Required for exception_detected."
    )
    data: dict[str, Any] = Field(default_factory=dict)
