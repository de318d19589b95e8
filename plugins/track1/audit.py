"""Track 1's audit checks: the agent's files against what it had been shown (public API).

Pure functions over what the host recorded (``simhost.host._records``' event models, the
protocol's ``HostMessage`` and ``ActionResult``) or the same as plain dicts, for the
organizers' audit (``eagc audit``) and for any other caller that must say the same thing
(a team's notes: early detections, ids never shown); each reads the fields it names through
a small model (``_Read``). Nothing here reads a file or the simulator.

What the agent was shown, step by step, goes into a ``Shown`` (``observe`` each
observation, ``message`` each host message, ``action`` each action and its result):

- instance ids: detections (``detections``, ``det_id``), the held item (``held``), the
  instance segmentation image when the split renders one, the ids a message names (a
  query's subject once detected), and the ids of actions whose result admits the id exists
  (any result but ``unknown_id`` and ``invalid_action``);
- room ids: the ``room`` observation (the sign read on entry) and the rooms messages name;
- states: each id's states as detections showed them, and the failure reasons of actions
  on it (``locked``, ``unavailable``: the only sign of those on the official splits).

Then:

- ``world_model_flags``: every id, room id and hidden-only state (a ``locked`` door, an
  ``unavailable`` container) in a ``world_model.json`` that nothing had shown by the step
  the snapshot was taken: a sign of access to hidden information.
- ``detection_flags``: every ``exception_detected`` record against the episode's
  exception (``Timeline``): the episode's type claimed before its first observable effect
  (before it happened, in an episode where it never did, or after it happened but before
  anything showed it) is flagged when the record names the exception's subject, a warning
  otherwise (a false alarm of the right type may be luck); another type is a false alarm,
  a note (the score already charges it).

On a split that hands over no ids (``vision``) the ids of a world model are the agent's
own: the id and hidden-state checks do not apply there (what would they be compared with?)
and are left out, with a note; the room check stays (the room sign shows room ids).

``Track1Checks`` is how ``eagc audit`` runs them (``Track1.audit``, ``plugins._audit``).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError

from plugins._audit import STEP_SLACK, AuditInput, EpisodeChecks, Finding, Snapshot
from plugins.track1._types import own_ids
from schemas import ActionResult, HostMessage, LogRecord, SchemaError, WorldModel, parse_json
from simhost.host import (
    ExceptionArmedEvent,
    ExceptionEvent,
    ExceptionObservableEvent,
    HostEventModel,
    parse_event,
)

Severity = Literal["flag", "warning", "note"]

#: Primitive names in action-index order (``simhost.worlds.track1.PRIMITIVES``; kept here so that
#: this module imports no simulator).
PRIMITIVES = ("noop", "move", "open", "close", "pick", "place", "use", "done")
#: Primitives whose ``target`` names an instance.
TARGETED = frozenset({"open", "close", "pick", "place", "use"})
#: Results that tell nothing about whether an id exists.
SILENT_REASONS = frozenset({"unknown_id", "invalid_action", "non_finite_action"})
#: States perception hides on the official splits: only a failed action shows them.
HIDDEN_STATES = {"locked": "locked", "unavailable": "unavailable"}
#: Message fields that carry an instance id, and those that carry room ids.
ID_KEYS = frozenset({"object", "door", "container", "tool", "target", "item", "receptacle"})
ROOM_KEYS = frozenset({"room", "rooms"})


class _Read(BaseModel):
    """What a check reads of a host record, an agent's value or a test's dict: the fields
    it names (from a dict or a model's attributes), the rest ignored."""

    model_config = ConfigDict(frozen=True, extra="ignore", from_attributes=True)


class _Detection(_Read):
    id: Any = None
    state: Any = None


class _Seen(_Read):
    """An observation's JSON entries."""

    detections: list[Any] | None = None


class _Message(_Read):
    """A host message (``HostMessage``, or its ``data`` alone)."""

    data: Any = None


class _Action(_Read):
    """A Track 1 action (``primitive`` an index or a name; ``target``, ``tool`` ids)."""

    primitive: Any = None
    target: Any = None
    tool: Any = None


class _Result(_Read):
    reason: Any = ""


class _GoalRef(_Read):
    kind: Any = None
    object: Any = None
    receptacle: Any = None
    tool: Any = None


class _TaskRef(_Read):
    goals: list[_GoalRef] | None = None


class _PlannedRef(_Read):
    type: Any = None
    goal: Any = None


class _Plan(_Read):
    """What the checks read of the hidden scenario's params (``Track1Scenario``)."""

    exception: _PlannedRef | None = None
    task: _TaskRef | None = None


@dataclass(frozen=True)
class Flag:
    """One finding of a check: what, where (the step), and why, in a sentence."""

    check: str
    severity: Severity
    message: str
    step: int | None = None
    subjects: tuple[str, ...] = ()
    """What it is about: ids, ``room <id>``, an exception type."""


def _as_id(value: Any) -> int | None:
    """An id as an agent may write it (``3`` or ``"3"``); None for anything else."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, str) and value.strip().lstrip("-").isdigit():
        return int(value)
    return None


@dataclass
class Shown:
    """What the agent had been shown, each item with the first step it was (module doc)."""

    ids: dict[int, int] = field(default_factory=dict)
    rooms: dict[int, int] = field(default_factory=dict)
    states: dict[int, dict[str, int]] = field(default_factory=dict)

    def _id(self, value: Any, step: int) -> None:
        i = _as_id(value)
        if i is not None and i >= 0 and self.ids.get(i, step + 1) > step:
            self.ids[i] = step

    def _room(self, value: Any, step: int) -> None:
        i = _as_id(value)
        if i is not None and i >= 0 and self.rooms.get(i, step + 1) > step:
            self.rooms[i] = step

    def _state(self, entity: int, state: str, step: int) -> None:
        seen = self.states.setdefault(entity, {})
        if seen.get(state, step + 1) > step:
            seen[state] = step

    def observe(self, step: int, data: Mapping[str, Any],
                tensors: Mapping[str, Any]) -> None:
        """One observation: its JSON entries and (any of) its tensors."""
        for entry in _Seen.model_validate(data).detections or ():
            if not isinstance(entry, Mapping):
                continue
            d = _Detection.model_validate(entry)
            i = _as_id(d.id)
            if i is not None:
                self._id(i, step)
                if isinstance(d.state, str):
                    self._state(i, d.state, step)
        for name in ("det_id", "held", "segmentation"):
            if name in tensors:
                for i in np.unique(np.asarray(tensors[name], dtype=np.int64)).tolist():
                    self._id(i, step)
        if "room" in tensors:
            for r in np.asarray(tensors["room"], dtype=np.int64).ravel().tolist():
                self._room(r, step)

    def message(self, step: int, message: HostMessage | Mapping[str, Any]) -> None:
        """One host message (instruction, queries, …): the ids and rooms it names."""

        def walk(value: Any, key: str | None) -> None:
            if isinstance(value, Mapping):
                for k, v in value.items():
                    walk(v, str(k))
            elif isinstance(value, list | tuple):
                for v in value:
                    walk(v, key)
            elif key in ID_KEYS:
                self._id(value, step)
            elif key in ROOM_KEYS:
                self._room(value, step)

        walk(_Message.model_validate(message).data, None)

    def action(self, step: int, action: Mapping[str, Any],
               result: ActionResult | Mapping[str, Any] | None) -> None:
        """One action and its result (an ``ActionResult`` or ``{ok, reason}``), ``step``
        the one it made."""
        act = _Action.model_validate(action)
        i = _as_id(act.primitive)
        name = PRIMITIVES[i] if i is not None and 0 <= i < len(PRIMITIVES) else act.primitive
        if name not in TARGETED or result is None:
            return
        reason = str(_Result.model_validate(result).reason or "")
        targets = [act.target] + ([act.tool] if name == "use" else [])
        for t in targets:
            i = _as_id(t)
            if i is None or reason in SILENT_REASONS:
                continue
            self._id(i, step)
            if reason in HIDDEN_STATES:
                self._state(i, HIDDEN_STATES[reason], step)

    # ---------------------------------------------------------------- queries
    def id_by(self, entity: int, step: int) -> bool:
        return self.ids.get(entity, step + 1) <= step

    def room_by(self, room: int, step: int) -> bool:
        return self.rooms.get(room, step + 1) <= step

    def state_by(self, entity: int, state: str, step: int) -> bool:
        return self.states.get(entity, {}).get(state, step + 1) <= step


def _spans(ids: Sequence[int]) -> str:
    """``1-3, 7`` for 1, 2, 3, 7."""
    runs: list[list[int]] = []
    for i in sorted(ids):
        if runs and runs[-1][1] == i - 1:
            runs[-1][1] = i
        else:
            runs.append([i, i])
    return ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)


def world_model_flags(model: WorldModel, shown: Shown, *, step: int,
                      where: str, own_ids: bool = False) -> list[Flag]:
    """What ``model`` holds that nothing had shown by ``step`` (module doc): at most one
    flag per check (ids, rooms, states), each listing what it found.

    Args:
        model: a ``world_model.json`` snapshot.
        shown: what the agent was shown over the whole episode (first step of each item).
        step: the host's step count when the snapshot was taken.
        where: the snapshot's name in the messages (e.g. ``exploration``).
        own_ids: the split shows no ids (``vision``): the model's are the agent's own, and
            only its rooms are checked.
    """
    if own_ids:
        return _room_flags(model, shown, step=step, where=where)
    flags: list[Flag] = []
    ids: dict[int, str] = {}
    for what, entries in (("door", model.doors), ("container", model.containers),
                          ("object", model.objects)):
        for e in entries:
            i = _as_id(e.id)
            if i is not None:
                ids.setdefault(i, what)
    for a in model.affordances:
        i = _as_id(a.tool)
        if i is not None:
            ids.setdefault(i, "tool")
    for c in model.connections:
        i = _as_id(c.door) if c.door is not None else None
        if i is not None:
            ids.setdefault(i, "door")
    never = sorted(i for i in ids if not shown.id_by(i, step))
    if never:
        kinds = {k: [i for i in never if ids[i] == k] for k in dict.fromkeys(ids.values())}
        listed = "; ".join(f"{k}s {_spans(v)}" for k, v in kinds.items() if v)
        flags.append(Flag("unseen_id", "flag", f"{where}: world_model.json holds "
                          f"{len(never)} id(s) never shown by step {step}: {listed}", step,
                          tuple(str(i) for i in never)))
    flags += _room_flags(model, shown, step=step, where=where)
    states: list[str] = []
    for what, entries in (("door", model.doors), ("container", model.containers)):
        for e in entries:
            i = _as_id(e.id)
            if i is None or e.state not in HIDDEN_STATES.values() or i in never:
                continue
            if not shown.state_by(i, e.state, step):
                states.append(f"{what} {i} {e.state}")
    if states:
        flags.append(Flag("unseen_state", "flag", f"{where}: world_model.json holds "
                          f"state(s) nothing had shown by step {step}: {', '.join(states)}",
                          step, tuple(x.split()[1] for x in states)))
    return flags


def _room_flags(model: WorldModel, shown: Shown, *, step: int, where: str) -> list[Flag]:
    """The room ids of ``model`` that nothing had shown by ``step``."""
    rooms: set[int] = set()
    for r in model.rooms:
        x = _as_id(r.id)
        if x is not None:
            rooms.add(x)
    for c in model.connections:
        rooms.update(x for x in (_as_id(v) for v in c.rooms) if x is not None)
    for e in (*model.containers, *model.objects):
        x = _as_id(e.room) if e.room is not None else None
        if x is not None:
            rooms.add(x)
    unseen = sorted(x for x in rooms if x >= 0 and not shown.room_by(x, step))
    if unseen:
        return [Flag("unseen_room", "flag", f"{where}: world_model.json holds "
                     f"{len(unseen)} room(s) never shown by step {step}: "
                     f"{_spans(unseen)}", step, tuple(f"room {r}" for r in unseen))]
    return []


@dataclass(frozen=True)
class Timeline:
    """The episode's exception as the host recorded it (``/eagc/event`` and the scenario)."""

    planned: str | None = None
    """The type the scenario planned (None: no exception planned)."""
    happened: str | None = None
    """The type applied (None: never applied)."""
    step: int | None = None
    """The step it was applied at."""
    effect_step: int | None = None
    """The first step its effect was observable (None: never)."""
    subject: int | None = None
    """The door, object, container or tool it changes (or would have changed)."""

    @classmethod
    def from_log(cls, scenario_params: Mapping[str, Any],
                 events: Iterable[HostEventModel | Mapping[str, Any]]) -> Timeline:
        """From the scenario's params and the episode's events, in log order (the
        ``/eagc/event`` records, as models or as written)."""
        params = _Plan.model_validate(scenario_params)
        planned = params.exception.type if params.exception is not None else None
        subject = _planned_subject(params)
        happened = step = effect = None
        for e in events:
            match e if isinstance(e, BaseModel) else _event(e):
                case ExceptionArmedEvent() as armed if armed.armed_on is not None:
                    subject = armed.armed_on
                case ExceptionEvent() as applied:
                    happened, step = applied.type, applied.step
                    subject = applied.subject if applied.subject is not None else subject
                case ExceptionObservableEvent() as seen if effect is None:
                    effect = seen.step
        return cls(planned=planned, happened=happened, step=step, effect_step=effect,
                   subject=subject)


def _event(data: Mapping[str, Any]) -> HostEventModel | None:
    """An event as written (a dict) as its model; None for one that does not read."""
    try:
        return parse_event(dict(data))
    except ValidationError:
        return None


def _planned_subject(params: _Plan) -> int | None:
    """What the planned exception would change, as far as the plan says (a door to lock is
    chosen only as execution starts)."""
    plan, goals = params.exception, (params.task.goals if params.task else None) or []
    k = _as_id(plan.goal) if plan is not None else None
    if plan is None or k is None or not 0 <= k < len(goals):
        return None
    g = goals[k]
    if plan.type == "container_unavailable":
        return _as_id(g.receptacle)
    if plan.type in ("object_relocation", "tool_substitution"):
        return _as_id(g.object if g.kind == "place" else g.tool)
    return None


def _named_ids(data: Any) -> set[int]:
    """Every integer a record's data holds (ids as an agent may write them)."""
    if isinstance(data, Mapping):
        return set().union(*(_named_ids(v) for v in data.values())) if data else set()
    if isinstance(data, list | tuple):
        return set().union(*(_named_ids(v) for v in data)) if data else set()
    i = _as_id(data)
    return set() if i is None else {i}


def detection_flags(records: Sequence[LogRecord], timeline: Timeline) -> list[Flag]:
    """Each ``exception_detected`` record against what could show it (module doc).

    A claim of the episode's exception type made before its first observable effect (by
    more than ``STEP_SLACK``) is flagged when the record names the exception's subject
    (it knew what would change), and a warning otherwise (a false alarm of the right type
    can be luck; the score already counts one made before the exception as a false
    alarm).
    """
    flags: list[Flag] = []
    for r in records:
        if r.event != "exception_detected":
            continue
        kind = r.exception_type
        real = timeline.happened or timeline.planned
        if kind != real:
            flags.append(Flag("false_alarm", "note", f"step {r.step}: {kind} claimed; the "
                              f"episode's exception is {real or 'none'}", r.step,
                              (str(kind),)))
            continue
        step = r.step + STEP_SLACK
        if timeline.step is None or step < timeline.step:
            why = ("it never happened" if timeline.step is None
                   else f"it happened at step {timeline.step}")
        elif timeline.effect_step is None or step < timeline.effect_step:
            why = (f"it happened at step {timeline.step} and "
                   + ("never showed" if timeline.effect_step is None
                      else f"first showed at step {timeline.effect_step}"))
        else:
            continue
        named = timeline.subject is not None and timeline.subject in _named_ids(r.data)
        flags.append(Flag(
            "early_detection", "flag" if named else "warning",
            f"step {r.step}: {kind} detected before anything could show it ({why})"
            + (f"; the record names its subject, {timeline.subject}" if named else ""),
            r.step, (str(kind),)))
    return flags


def check_episode(shown: Shown, *, scenario_params: Mapping[str, Any],
                  events: Sequence[HostEventModel | Mapping[str, Any]],
                  snapshots: Sequence[Snapshot],
                  log: Sequence[LogRecord]) -> list[Flag]:
    """Every check of this module on one episode.

    Args:
        shown: what the agent was shown (fed from the whole episode).
        scenario_params: the hidden scenario's params (``/eagc/scenario``).
        events: the host's events in log order (``/eagc/event``, as models or as
            written).
        snapshots: the files at each stage end and at the end, in time order.
        log: the final ``episode_log.jsonl`` records.
    """
    flags: list[Flag] = []
    own = own_ids(scenario_params)
    if own:
        flags.append(Flag("own_ids", "note", "the split shows no ids (vision): the world "
                          "models' ids are the agent's own; only their rooms are checked"))
    for snap in snapshots:
        blob = snap.files.get("world_model.json")
        if blob is None:
            continue
        try:  # graded as the score grades it: keys nothing reads ignored, not refused
            model = parse_json(blob, WorldModel, source=f"{snap.name}/world_model.json")
        except SchemaError:
            flags.append(Flag("unreadable_file", "note", f"{snap.name}: world_model.json "
                              "does not parse: not checked", snap.step))
            continue
        flags += world_model_flags(model, shown, step=snap.step, where=snap.name,
                                   own_ids=own)
    flags += detection_flags(log, Timeline.from_log(scenario_params, events))
    return flags


class Track1Checks(EpisodeChecks):
    """This module's checks as ``eagc audit`` runs them (``Track1.audit``): fed a ``Shown``
    as the log is read, then ``check_episode``."""

    def __init__(self) -> None:
        self.shown = Shown()

    def observe(self, step: int, data: Mapping[str, Any], tensors: Mapping[str, Any]) -> None:
        self.shown.observe(step, data, tensors)

    def message(self, step: int, message: HostMessage) -> None:
        self.shown.message(step, message)

    def action(self, step: int, action: Mapping[str, Any], result: ActionResult) -> None:
        self.shown.action(step, action, result)

    def findings(self, episode: AuditInput) -> list[Finding]:
        flags = check_episode(self.shown, scenario_params=episode.scenario.params,
                              events=episode.events, snapshots=episode.snapshots,
                              log=episode.log)
        return [Finding(check=f.check, severity=f.severity, message=f.message, step=f.step,
                        subjects=f.subjects) for f in flags]
