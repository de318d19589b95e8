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

from pydantic import BaseModel, ConfigDict, Field, model_validator

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
    state: str | None = Field(
        default=None, description="Visible state (dirty, sliced, …); 'removed' when gone."
    )


class Affordance(_File):
    tool: Id
    affordance: str


class WorldModel(_File):
    """``world_model.json``: the agent's queryable model of the house (Track 1).

    Ids are the ones observations expose: room ids from the ``room`` observation, instance
    ids of doors, containers, objects and tools from the detections; positions are world
    x, y (m) in the odometry frame. Track 1 grades the snapshot taken when exploration ends
    (room-graph edges, object inventory by category and room with a position tolerance,
    door and container states, tool affordances) and, after an exception, the final file.
    """

    version: Literal["eagc-world-model/v1"] = WORLD_MODEL_VERSION
    step: int | None = Field(default=None, description="Agent step at which it was written.")
    rooms: list[Room] = Field(default_factory=list)
    connections: list[Connection] = Field(default_factory=list)
    doors: list[DoorState] = Field(default_factory=list)
    containers: list[ContainerState] = Field(default_factory=list)
    objects: list[ObjectEntry] = Field(default_factory=list)
    affordances: list[Affordance] = Field(default_factory=list)


class NamedItem(_File):
    """A named value, e.g. a constraint: ``{"name": "clearance", "value": 0.004}``."""

    name: str
    value: Any = None
    description: str = ""


class StateVariable(_File):
    """A state variable the task depends on, e.g. ``peg_pose`` of part ``peg``."""

    name: str
    type: Literal["pose", "position", "angle", "fraction", "length", "bool"] | None = None
    part: str | None = Field(default=None, description="The part it describes, if any.")
    value: Any = Field(default=None, description="Its value when the file was written.")
    description: str = ""


class Precondition(_File):
    """What must hold to enter ``stage``: predicates such as ``peg_grasped``."""

    stage: str
    requires: list[str] = Field(default_factory=list)


class SuccessCriterion(_File):
    """One condition of success; all of them must hold at once.

    ``value`` is a number or bool, or ``[low, high]`` with ``op == "within"``.
    """

    variable: str
    op: Literal[">=", "<=", "==", "within"]
    value: Any = None
    description: str = ""


class TaskModel(_File):
    """``task_model.json`` (Track 2): the task inferred from the demonstration.

    Names follow the bench's public vocabulary (``simhost.track2.task_truth``,
    ``plugins/track2/README.md``): e.g. insertion has stages ``reach grasp transport align
    insert release``, variables ``peg_pose``, constraints ``clearance``, preconditions
    ``{"stage": "insert", "requires": ["peg_grasped", "peg_aligned"]}`` and success
    ``insertion_depth >= 0.02``. It is compared with the truth of the hidden instance being
    executed, whose goals are stated relative to the attempt's start as the demonstration
    defines them (rotation: ``knob_turn within [1.15, 1.25]``, a turn, not an angle); the
    values (constraints, success criteria) weigh more than the names.
    """

    version: Literal["eagc-task-model/v1"] = TASK_MODEL_VERSION
    step: int | None = Field(default=None, description="Agent step at which it was written.")
    family: str | None = Field(
        default=None,
        description="insertion, rotation, assembly, opening or tool_use; a wrong family "
        "makes the whole model wrong.",
    )
    stages: list[str] = Field(default_factory=list, description="Ordered key stages.")
    variables: list[StateVariable] = Field(default_factory=list)
    constraints: list[NamedItem] = Field(default_factory=list)
    preconditions: list[Precondition] = Field(default_factory=list)
    success_criteria: list[SuccessCriterion] = Field(default_factory=list)


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
    """One line of ``episode_log.jsonl``.

    A valid log (``schemas.parse_episode_log``) has at least one record, one JSON object
    per line (blank lines are ignored), records in time order (``step`` never decreases),
    and an ``exception_type`` on every ``exception_detected`` record.
    """

    step: int = Field(ge=0, description="Agent step count when the record was written.")
    stage: str | None = None
    event: LogEvent
    exception_type: ExceptionType | None = Field(
        default=None, description="Required for exception_detected."
    )
    data: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _exception_named(self) -> LogRecord:
        if self.event == "exception_detected" and self.exception_type is None:
            raise ValueError("an exception_detected record names its exception_type")
        return self
