"""The typed vocabulary of Track 1: scenario, task, goals, planned exception, queries, plan
and the episode's outcome. Everything that crosses a module of this track is one of these
(frozen pydantic models; ``model_dump(mode="json")`` is what the MCAP log and the scorer
see, and ``model_validate`` reads it back).
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from plugins._base import HiddenScenario, ScenarioSource
from simhost.host import EpisodeOutcome
from simhost.worlds.track1 import HouseSplit, HouseTruth

ExceptionType = Literal["door_lock", "object_relocation", "container_unavailable",
                        "tool_substitution"]
EXCEPTION_TYPES: tuple[ExceptionType, ...] = ("door_lock", "object_relocation",
                                              "container_unavailable", "tool_substitution")
"""Table III of the paper."""

QueryKind = Literal["object_room", "door_state", "room_neighbours", "container_state",
                    "tools_for", "object_count"]


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class Goal(_Frozen):
    """One clause of the instruction: put an object somewhere, or use a tool on a target.

    ``place``: ``object`` ends on or in ``receptacle`` (or, once the named container turned
    out unusable, in one of ``substitutes``: the other containers of its room). ``use``:
    ``target`` reaches the after-state of ``affordance`` by ``tool`` (or, once the named
    tool is gone, by one of ``substitutes``: the other tools with that use).
    """

    kind: Literal["place", "use"]
    object: int | None = None
    receptacle: int | None = None
    container: bool = False
    target: int | None = None
    tool: int | None = None
    affordance: str | None = None
    substitutes: tuple[int, ...] = ()
    subgoals: tuple[str, ...]
    """Key subgoals in order: ``picked, reached, [opened,] placed`` or ``picked, reached,
    used``."""

    @property
    def fetched(self) -> int:
        """What the robot must pick up: the object, or the tool."""
        out = self.object if self.kind == "place" else self.tool
        assert out is not None
        return out

    @property
    def destination(self) -> int:
        """Where it goes, or what it acts on."""
        out = self.receptacle if self.kind == "place" else self.target
        assert out is not None
        return out


class Task(_Frozen):
    """The instruction and its goals (all must hold at the end)."""

    text: str
    steps: tuple[str, ...]
    """The instruction's steps in plain words (ALFRED's step-by-step descriptions)."""
    goals: tuple[Goal, ...] = Field(min_length=1)
    substitute_rule: str = ""
    """Said with the instruction on the dev split only."""


class PlannedException(_Frozen):
    """The controlled exception the scenario plans (it may still be skipped at run time)."""

    type: ExceptionType
    goal: int
    """Index of the goal it targets."""


class Query(_Frozen):
    """One question about the house asked at the start of planning, by description.

    ``subject`` is what the truth is looked up by (an instance id, a room id, an
    affordance or a category); it is shown to the agent only as ``ids`` allow (an id the
    agent never detected is not revealed).
    """

    id: str
    kind: QueryKind
    subject: int | str
    text: str
    about: dict[str, Any] = Field(default_factory=dict)
    """The description in fields (category, colour, room ids, …), as the agent sees it."""


class Track1Scenario(_Frozen, HiddenScenario):
    """One hidden Track 1 scenario (organizer-only); ``Track1Scenario.of(scenario)`` reads
    one back from a ``Scenario``, the log's ``ScenarioRecord`` or its params."""

    split: HouseSplit
    layout_digest: str
    rooms: int
    task: Task
    exception: PlannedException | None
    queries: tuple[Query, ...]
    budgets: dict[str, int] = Field(default_factory=dict)
    """Step budget per stage, derived from the ground truth (``_budgets``)."""


def own_ids(scenario: ScenarioSource) -> bool:
    """Whether the scenario's split shows no ids (no detector: ``vision``): the agent's
    files then name things by ids of its own, which the score matches to the truth's
    (``_matching``) and the audit does not hold against what was shown. False for params
    that do not read as a Track 1 scenario."""
    try:
        return not Track1Scenario.of(scenario).split.config.detections
    except ValidationError:
        return False


class Track1Plan(BaseModel):
    """The plan an agent submits in the ``end_stage`` payload that ends planning."""

    model_config = ConfigDict(extra="ignore")

    subgoals: list[str] = Field(default_factory=list, max_length=100)
    route: list[int] = Field(default_factory=list, max_length=100,
                             description="Room ids in visiting order.")
    doors: list[int] = Field(default_factory=list, max_length=100,
                             description="Door ids in crossing order.")


class ExceptionRecord(_Frozen):
    """The exception as it happened."""

    type: ExceptionType
    goal: int
    subject: int
    """The door, object, container or tool it changed."""
    step: int
    """The episode step at which it was applied."""
    pose: tuple[float, float]
    """Where the robot was then."""
    details: dict[str, Any]
    """The environment's event (e.g. the receptacle an object moved to)."""
    effect_step: int | None = None
    """The first step at which the agent could observe it (None: never)."""


class GoalProgress(_Frozen):
    subgoals: dict[str, int | None]
    """Key subgoal → the step it was first reached (None: never)."""
    done: bool
    """Whether the goal holds at the end."""


class GradedQuery(_Frozen):
    id: str
    kind: QueryKind
    text: str
    truth: Any
    answer: Any
    score: float


class ExecutionStats(_Frozen):
    start_step: int | None = None
    start_pose: tuple[float, float] | None = None
    steps: int = 0
    redundant: int = 0
    """No-ops, failed actions and moves that went nowhere."""
    path_at_success: float | None = None
    """Metres driven in execution until the task first held."""
    reference_length: float | None = None
    """The shortest room-respecting path through the true access poses (metres)."""


class ShownRecord(_Frozen):
    """What the agent was shown, each item with the first step it was shown (the audit's
    ``Shown``: ``_episode.shown_record`` and ``shown_from`` convert)."""

    ids: dict[int, int] = Field(default_factory=dict)
    """Instance id -> step."""
    rooms: dict[int, int] = Field(default_factory=dict)
    """Room id -> step."""
    states: dict[int, dict[str, int]] = Field(default_factory=dict)
    """Instance id -> state -> step."""


class Track1Outcome(EpisodeOutcome):
    """What the scorer reads of one episode (``Track1Episode.outcome``)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    started: bool
    task: Task
    planned_exception: PlannedException | None
    exception: ExceptionRecord | None = None
    exception_skipped: str | None = None
    success: bool = False
    goals: tuple[GoalProgress, ...] = ()
    plan: Track1Plan | None = None
    plan_error: str = ""
    queries: tuple[GradedQuery, ...] = ()
    gt_exploration: HouseTruth | None = None
    gt_final: HouseTruth | None = None
    steps: int = 0
    stage_steps: dict[str, int] = Field(default_factory=dict)
    path: dict[str, float] = Field(default_factory=dict)
    execution: ExecutionStats = Field(default_factory=ExecutionStats)
    collisions: int = 0
    deadlocks: int = 0
    shown: ShownRecord | None = None
    """What the agent was shown (the score's notes; None: not recorded)."""

    @property
    def subgoal_fraction(self) -> float:
        """Key subgoals reached, over all goals."""
        marks = [v for g in self.goals for v in g.subgoals.values()]
        return sum(v is not None for v in marks) / len(marks) if marks else 0.0
