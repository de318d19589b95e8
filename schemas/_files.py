"""The structured files an agent writes to ``/output`` (paper §II-C).

- ``world_model.json`` (Track 1, and the sanity track): the agent's queryable model of the
  world — rooms and how they connect, doors, containers, objects, tool affordances.
- ``task_model.json`` (Track 2): stages, variables, constraints, preconditions and success
  criteria inferred from the demonstration.
- ``episode_log.jsonl`` (both tracks): one record per line, in time order.

Agents should write to a temporary name and rename, so that a snapshot never sees half a file.

Fields a track does not grade are allowed: an unknown key (at the top level or inside an
entry) is ignored, and the score card's notes list it (``schemas.ignored_fields``). A file
is refused only when what the score reads cannot be read. Fields marked ``graded`` in the
JSON Schemas are the ones the tracks' scores read.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Final, Literal, get_args

from pydantic import AliasChoices, BaseModel, ConfigDict, Field, PrivateAttr, model_validator

WORLD_MODEL_VERSION: Final = "eagc-world-model/v1"
TASK_MODEL_VERSION: Final = "eagc-task-model/v1"

Id = int | str


def graded(default: Any = ..., description: str = "", **kw: Any) -> Any:
    """A field a track's score reads (``"graded": true`` in the JSON Schema)."""
    return Field(default, description=f"Graded. {description}".strip(),
                 json_schema_extra={"graded": True}, **kw)


class _File(BaseModel):
    """A part of an agent's file: unknown keys are ignored (and listed, never an error)."""

    model_config = ConfigDict(extra="ignore", json_schema_extra={"additionalProperties": True})
    #: Paths of the keys this object's file held that no model field takes (set by
    #: ``schemas.parse_json`` / ``parse_jsonl`` on the file's top object or record).
    _ignored: tuple[str, ...] = PrivateAttr(default=())
    #: The report lines of the fields nothing grades whose value could not be read (set
    #: alike): ignored, as unknown keys are.
    _unreadable: tuple[str, ...] = PrivateAttr(default=())
    #: The notes on the near-miss shapes the file held (``NearMiss.note``; set alike).
    _near_misses: tuple[str, ...] = PrivateAttr(default=())

    def near_miss_notes(self) -> tuple[str, ...]:
        """One note per near-miss shape the file held (its model's ``near_misses``): the
        shape found, what the score made of it, and the shape the model reads, with an
        example. Empty for an object not read by ``schemas.parse_json``."""
        return self._near_misses


def _example(*examples: dict[str, Any]) -> ConfigDict:
    return ConfigDict(extra="ignore", json_schema_extra={"additionalProperties": True,
                                                          "examples": list(examples)})


class Room(_File):
    """A room, by the id of the ``room`` observation."""

    model_config = _example({"id": 3, "type": "kitchen"})

    id: Id = Field(description="The room id the ``room`` observation shows.")
    type: str | None = Field(default=None, description="kitchen, bedroom, … or null.")


class Connection(_File):
    """Two rooms that connect, through a door or an open doorway."""

    model_config = _example({"rooms": [3, 5], "door": 41})

    rooms: tuple[Id, Id] = graded(description="The two room ids (Track 1: room-graph edges).")
    door: Id | None = None


class DoorState(_File):
    """A door and its state."""

    model_config = _example({"id": 41, "state": "closed"})

    id: Id = graded(description="The door's instance id.")
    state: Literal["open", "closed", "locked", "unknown"] = graded()


class ContainerState(_File):
    """A container (cabinet, fridge, …) and its state."""

    model_config = _example({"id": 52, "type": "fridge", "room": 3, "state": "closed"})

    id: Id = graded(description="The container's instance id.")
    type: str | None = None
    room: Id | None = None
    state: Literal["open", "closed", "unavailable", "unknown"] = graded()


class ObjectEntry(_File):
    """An object or tool: what it is, where it is."""

    model_config = _example({"id": 17, "category": "cup", "colour": "red", "room": 3,
                             "receptacle": 52, "position": [1.2, -0.4], "state": None})

    id: Id = graded(description="The instance id of the detections.")
    category: str | None = graded(None, "Inventory: category, room and position.")
    colour: str | None = None
    room: Id | None = graded(None, "The room id it is in.")
    receptacle: Id | None = Field(default=None, description="Furniture or container it is on/in.")
    position: tuple[float, float] | None = graded(None, "World x, y (m).")
    state: str | None = graded(
        None, "Visible state (dirty, sliced, …); 'removed' when gone."
    )


class Affordance(_File):
    """What a tool can do (``plugins/track1/README.md`` names the affordances)."""

    model_config = _example({"tool": 23, "affordance": "cut"})

    tool: Id = graded(description="The tool's instance id.")
    affordance: str = graded()


def example_of(model: type[BaseModel]) -> Any:
    """The first example of ``model``'s JSON Schema (None when it has none)."""
    extra = model.model_config.get("json_schema_extra")
    examples = extra.get("examples") if isinstance(extra, dict) else None
    return examples[0] if isinstance(examples, list) and examples else None


def _json(value: Any) -> str:
    return json.dumps(value, separators=(", ", ": "), ensure_ascii=False)


@dataclass(frozen=True)
class NearMiss:
    """A shape a team is likely to write where the file's model reads another: found in
    the file as written (``schemas.parse_json``), noted with the shape the model reads.

    ``at`` is where it is found, as a path whose ``[]`` steps into each entry of a list
    (``topology[].frontiers[]``); ``test`` is true of each entry there in this shape
    (None: found by the track, whose vocabulary it needs); with ``leave_out``, those
    entries are left out before the file is read (they would refuse it), else read as
    they are (an unknown key is ignored). ``found`` says what they are; a ``{keys}`` in
    it is the first entry's keys. ``lost`` says what the score made of them. ``fields``
    are the model's fields that take what they hold, each shown by its example.
    """

    at: str
    found: str
    lost: str
    fields: tuple[str, ...]
    test: Callable[[Any], bool] | None
    leave_out: bool = False

    @property
    def key(self) -> str:
        """The top-level key it is under."""
        return self.at.split("[")[0].split(".")[0]

    def entries(self, doc: Mapping[str, Any]) -> list[Any]:
        """Every entry at ``at`` in ``doc`` (a file's JSON), whatever its shape."""
        level: list[Any] = [doc]
        for part in self.at.split("."):
            name = part.removesuffix("[]")
            level = [x.get(name) for x in level if isinstance(x, dict)]
            if part.endswith("[]"):
                level = [e for x in level if isinstance(x, list) for e in x]
        return level

    def find(self, doc: Mapping[str, Any]) -> tuple[list[Any], int]:
        """The entries of ``doc`` in this shape, and how many entries ``at`` holds."""
        entries = self.entries(doc)
        if self.test is None:
            return [], len(entries)
        return [e for e in entries if self.test(e)], len(entries)

    def note(self, found: Sequence[Any], total: int, model: type[BaseModel],
             width: int = 80) -> str:
        """The note on ``found`` (entries in this shape, or what names them) of the
        ``total`` at ``at`` in a file of ``model``: ``rooms: 2 of 2 entries are names,
        not objects ("bedroom", "hall"): …; eagc reads rooms: [{"id": 3, …}]``."""
        shown: list[str] = []
        for value in found:
            text = _json(value)
            if shown and sum(map(len, shown)) + len(text) > width:
                break
            shown.append(text if len(text) <= width else text[:width - 1] + "…")
        values = ", ".join(shown) + (", …" if len(shown) < len(found) else "")
        first = found[0] if found else None
        keys = "{" + ", ".join(map(str, first)) + "}" if isinstance(first, dict) else ""
        expected = " and ".join(
            f"{f}: [{_json(example_of(get_args(model.model_fields[f].annotation)[0]))}]"
            for f in self.fields)
        return (f"{self.at.removesuffix('[]')}: {len(found)} of {total} entries "
                f"{self.found.format(keys=keys)} ({values}): {self.lost}; eagc reads "
                f"{expected}")


def _is_name(entry: Any) -> bool:
    return isinstance(entry, str | int | float) and not isinstance(entry, bool)


def _is_triple(entry: Any) -> bool:
    return isinstance(entry, dict) and {"entity", "attribute", "value"} <= set(entry)


def _not_a_pair(entry: Any) -> bool:
    return (isinstance(entry, dict) and not {"tool", "affordance"} & set(entry)
            and bool({"object", "actions", "action"} & set(entry)))


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
    connections: list[Connection] = graded(default_factory=list)
    doors: list[DoorState] = graded(default_factory=list)
    containers: list[ContainerState] = graded(default_factory=list)
    objects: list[ObjectEntry] = graded(default_factory=list)
    affordances: list[Affordance] = graded(default_factory=list)

    #: The near-miss shapes teams wrote before eagc existed (issue 35), each noted where
    #: it is found; ``objects`` is found by the track (its door and container words).
    near_misses: ClassVar[tuple[NearMiss, ...]] = (
        NearMiss("rooms[]", "are names, not objects",
                 "left out (rooms are not graded; the room graph is graded from "
                 "connections)", ("rooms",), _is_name, leave_out=True),
        NearMiss("topology[].frontiers[]",
                 "are room links under topology, a key eagc does not read",
                 "the room graph is graded from connections", ("connections",),
                 lambda entry: True),
        NearMiss("states[]",
                 "are {keys} triples, a key eagc does not read",
                 "door and container states are graded from doors and containers",
                 ("doors", "containers"), _is_triple),
        NearMiss("affordances[]", "are {keys}, not a tool and an affordance",
                 "left out, not graded", ("affordances",), _not_a_pair, leave_out=True),
        NearMiss("objects[]", "are doors or containers",
                 "graded as objects, which they match none of; door and container "
                 "states are graded from doors and containers",
                 ("doors", "containers"), None),
    )


class NamedItem(_File):
    """A named value, e.g. a constraint: ``{"name": "clearance", "value": 0.004}``."""

    model_config = _example({"name": "clearance", "value": 0.004})

    name: str = graded()
    value: Any = graded(None)
    description: str = ""


class StateVariable(_File):
    """A state variable the task depends on, e.g. ``peg_pose`` of part ``peg``."""

    model_config = _example({"name": "peg_pose", "type": "pose", "part": "peg"})

    name: str = graded()
    type: Literal["pose", "position", "angle", "fraction", "length", "bool"] | None = None
    part: str | None = Field(default=None, description="The part it describes, if any.")
    value: Any = Field(default=None, description="Its value when the file was written.")
    description: str = ""


class Precondition(_File):
    """What must hold to enter ``stage``: predicates such as ``peg_grasped``."""

    model_config = _example({"stage": "insert", "requires": ["peg_grasped", "peg_aligned"]})

    stage: str = graded()
    requires: list[str] = graded(default_factory=list)


class SuccessCriterion(_File):
    """One condition of success; all of them must hold at once.

    ``value`` is a number or bool, or ``[low, high]`` with ``op == "within"``.
    """

    model_config = _example({"variable": "insertion_depth", "op": ">=", "value": 0.02})

    variable: str = graded()
    op: Literal[">=", "<=", "==", "within"] = graded()
    value: Any = graded(None)
    description: str = ""


class TaskModel(_File):
    """``task_model.json`` (Track 2): the task inferred from the demonstration.

    Names follow the bench's public vocabulary (``simhost.worlds.track2.task_truth``,
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
    family: str | None = graded(
        None,
        "insertion, rotation, assembly, opening or tool_use; a wrong family "
        "makes the whole model wrong.",
    )
    stages: list[str] = graded(default_factory=list, description="Ordered key stages.")
    variables: list[StateVariable] = graded(default_factory=list)
    constraints: list[NamedItem] = graded(default_factory=list)
    preconditions: list[Precondition] = graded(default_factory=list)
    success_criteria: list[SuccessCriterion] = graded(default_factory=list)


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

#: What each ``LogEvent`` says, one line each (``eagc check-files`` lists them for a value
#: that is not ours). Only ``exception_detected`` is graded; the others are for the reader.
EVENT_MEANINGS: dict[str, str] = {
    "observation": "what the agent saw; not graded",
    "action": "an action the agent took; not graded",
    "plan": "the plan the agent made; not graded",
    "replan": "the plan changed, e.g. after an exception; not graded",
    "model_update": "the agent changed its world or task model; not graded",
    "exception_detected": "the agent noticed an exception and names its "
                          "exception_type; graded: the detection and its step",
    "stage": "a stage begins; the record's stage names it; not graded",
    "attempt": "an attempt at the task or a subgoal begins; not graded",
    "note": "anything else worth reading; not graded",
}

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

    model_config = _example(
        {"step": 0, "stage": "exploration", "event": "stage", "data": {}},
        {"step": 180, "stage": "execution", "event": "exception_detected",
         "exception_type": "door_lock", "data": {"door": 41}})

    step: int = graded(ge=0, description="Agent step count when the record was written.")
    stage: str | None = None
    event: LogEvent = graded(validation_alias=AliasChoices("event", "event_type"),
                             description="What happened (``event_type`` is read too).")
    exception_type: ExceptionType | None = graded(
        None, "Required for exception_detected."
    )
    data: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _exception_named(self) -> LogRecord:
        if self.event == "exception_detected" and self.exception_type is None:
            raise ValueError("an exception_detected record names its exception_type")
        return self
