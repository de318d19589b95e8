"""Track 1's score, equation (1): ``0.40 task + 0.20 model + 0.20 recovery + 0.10 efficiency
+ 0.10 safety``, each component in [0, 1], paying only for what was achieved (an agent that
does nothing scores about 0 on every component).

- **task**: 0.6 × main objective (every goal of the instruction holds at the end) + 0.4 ×
  the fraction of key subgoals reached (per goal: picked, reached, [opened,] placed or
  used).
- **model**: the ``world_model.json`` snapshot taken when exploration ended, against the
  ground truth of the whole house at that moment (seen or not): room-graph edge F1 (0.25),
  object inventory F1 by category and room with the position within
  ``POSITION_TOLERANCE`` (0.25), door and container state accuracy over every door and
  container (0.15; a missing entry is wrong), (tool, affordance) F1 (0.10), and the query
  answers (0.25; ``_queries``: asked by description about things seen or not, an unknown
  answer scores 0, never less).
- **recovery**: with an exception, a third each for detecting it (an
  ``exception_detected`` log record of the right type from the step it happened until
  ``DETECT_WINDOW`` steps after its first observable effect), updating the final model
  (the door locked, the object in its new room, the container unavailable, a substitute
  tool listed and the missing one not) and completing the task by a valid alternative. An
  exception planned but never triggered (the agent never came where it matters) counts as
  missed. Without an exception the weight stays on recovery and is earned by completing
  the task without a false alarm. A false alarm (an ``exception_detected`` record of
  another type, before the exception happened, or in an episode without one) takes
  ``FALSE_ALARM_COST`` off the detection (or off the whole component without an
  exception), floor 0.
- **efficiency**: for a completed task, SPL over execution (the reference is the shortest
  room-respecting route from where execution started through the true access poses of what
  the goals move and where, over the path driven until the task held) × (1 − the fraction
  of redundant execution actions: no-ops, failed actions, moves that went nowhere); 0
  otherwise.
- **safety**: the task component (progress) × ``max(0, 1 − 2 × bad / steps)``, where bad
  counts invalid actions and protocol errors, half of each collision, and 5 per deadlock
  (30 steps without progress) and per MuJoCo warning (at most 3).

On a split without a detector (``vision``) the world-model files and the ``tools_for``
answers use the agent's own ids: ``_matching`` renames them to the true ids they pair with
by category and position before any of the above is computed (``_types.own_ids``).

The card's notes say where credit was thrown away (``credit_notes``), with the audit's own
checks (``plugins.track1.audit``: ``detection_flags``, ``world_model_flags``) on what the
episode recorded it showed the agent: an ``exception_detected`` before the exception, an
exception never detected, ids and room ids in the model that match nothing the agent was
shown, the world model's near-miss shapes with the shape it should have
(``shape_notes``), log steps that disagree with the host's count, queries left
unanswered, and the keys of the files nothing grades.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, get_args

from plugins._audit import HostSteps, log_step_findings
from plugins._base import ScoringInput
from plugins.track1._episode import EXECUTION, EXPLORATION, PLANNING, shown_from
from plugins.track1._matching import (
    UNMATCHED,
    IdMatch,
    match,
    matched,
    rename,
    rename_answer,
)
from plugins.track1._queries import f1, score_answer
from plugins.track1._types import (
    ExceptionRecord,
    GradedQuery,
    Track1Outcome,
    Track1Scenario,
    own_ids,
)
from plugins.track1.audit import (
    Shown,
    Timeline,
    _as_id,
    _spans,
    detection_flags,
    world_model_flags,
)
from schemas import (
    ContainerState,
    DoorState,
    LogRecord,
    ObjectEntry,
    ScoreCard,
    WorldModel,
    ignored_note,
)
from simhost.worlds.track1 import CONTAINER_CATEGORIES, HouseTruth

WEIGHTS = {"task": 0.40, "model": 0.20, "recovery": 0.20, "efficiency": 0.10, "safety": 0.10}
MODEL_PARTS = {"topology": 0.25, "objects": 0.25, "states": 0.15, "affordances": 0.10,
               "queries": 0.25}
POSITION_TOLERANCE = 0.75
DETECT_WINDOW = 30
FALSE_ALARM_COST = 0.5


def _key(value: Any) -> Any:
    """Ids as the agent may write them (``3`` or ``"3"``) compare equal."""
    if isinstance(value, str) and value.strip().lstrip("-").isdigit():
        return int(value)
    return value


def topology(model: WorldModel, gt: HouseTruth) -> float:
    """F1 of the room graph's edges (room pairs)."""
    truth = {frozenset(c.rooms) for c in gt.connections}
    given = {frozenset(_key(r) for r in c.rooms) for c in model.connections}
    return f1({g for g in given if len(g) == 2}, truth)


def inventory(model: WorldModel, gt: HouseTruth) -> float:
    """F1 of the object inventory: same category and room, position within tolerance."""
    truth = [(o.category, o.room, o.position[:2]) for o in gt.objects]
    given = [o for o in model.objects if o.category is not None]
    if not truth and not given:
        return 1.0
    used: set[int] = set()
    hits = 0
    for cat, room, pos in truth:
        best, best_d = None, POSITION_TOLERANCE
        for k, o in enumerate(given):
            if k in used or o.category != cat or _key(o.room) != room or o.position is None:
                continue
            d = math.dist(o.position, pos)
            if d <= best_d:
                best, best_d = k, d
        if best is not None:
            used.add(best)
            hits += 1
    return 0.0 if hits == 0 else 2 * hits / (len(truth) + len(given))


def states(model: WorldModel, gt: HouseTruth) -> float:
    """Accuracy of the door and container states (a missing entry is wrong)."""
    doors = {_key(d.id): d.state for d in model.doors}
    boxes = {_key(c.id): c.state for c in model.containers}
    truth = [(doors, d.id, d.state) for d in gt.doors]
    truth += [(boxes, c.id, c.state) for c in gt.containers]
    if not truth:
        return 1.0
    return sum(table.get(i) == s for table, i, s in truth) / len(truth)


def affordances(model: WorldModel, gt: HouseTruth) -> float:
    """F1 of (tool id, affordance) pairs of the available tools."""
    truth = {(a.tool, a.affordance) for a in gt.affordances}
    return f1({(_key(a.tool), a.affordance) for a in model.affordances}, truth)


def model_parts(model: WorldModel | None, gt: HouseTruth | None,
                queries: Sequence[GradedQuery]) -> dict[str, float]:
    """The parts of the model score (each in [0, 1])."""
    parts = {"queries": sum(q.score for q in queries) / len(queries) if queries else 0.0}
    for name, fn in (("topology", topology), ("objects", inventory), ("states", states),
                     ("affordances", affordances)):
        parts[name] = 0.0 if model is None or gt is None else fn(model, gt)
    return parts


def updated(rec: ExceptionRecord, model: WorldModel | None, gt: HouseTruth) -> bool:
    """Whether the final model shows what the exception changed."""
    if model is None:
        return False
    subject = rec.subject
    if rec.type == "door_lock":
        return any(_key(d.id) == subject and d.state == "locked" for d in model.doors)
    if rec.type == "container_unavailable":
        return any(_key(c.id) == subject and c.state == "unavailable" for c in model.containers)
    if rec.type == "object_relocation":
        obj = gt.object(subject)
        return obj is not None and any(_key(o.id) == subject and _key(o.room) == obj.room
                                       for o in model.objects)
    tool = next((t for t in gt.tools if t.id == subject), None)
    if tool is None:
        return False
    listed = {_key(a.tool) for a in model.affordances if a.affordance in tool.affordances}
    present = any(_key(o.id) == subject and o.state not in ("removed", "unavailable", "missing")
                  for o in model.objects)
    substitutes = {t.id for t in gt.tools if t.available
                   and set(t.affordances) & set(tool.affordances)}
    return bool(listed & substitutes) and subject not in listed and not present


def recovery_parts(o: Track1Outcome, log: Iterable[LogRecord], model: WorldModel | None
                   ) -> tuple[dict[str, float], bool]:
    """The recovery parts, and whether the episode had an exception (planned and not
    skipped). With one: detected, updated, completed; without: completed (no false alarm)."""
    claims = [r for r in log if r.event == "exception_detected"]
    success = float(o.success)
    rec = o.exception
    if rec is None:
        if o.planned_exception is not None and o.exception_skipped is None:
            return {"detected": 0.0, "updated": 0.0, "completed": success}, True
        penalty = max(0.0, 1.0 - FALSE_ALARM_COST * len(claims))
        return {"completed": success * penalty}, False
    last = (rec.effect_step if rec.effect_step is not None else o.steps) + DETECT_WINDOW
    hit = any(r.exception_type == rec.type and rec.step <= r.step <= last for r in claims)
    false = sum(1 for r in claims if r.exception_type != rec.type or r.step < rec.step)
    return {
        "detected": float(hit) * max(0.0, 1.0 - FALSE_ALARM_COST * false),
        "updated": float(o.gt_final is not None and updated(rec, model, o.gt_final)),
        "completed": success,
    }, True


def efficiency(o: Track1Outcome) -> float:
    ex = o.execution
    ref, driven = ex.reference_length, ex.path_at_success
    if not o.success or ref is None or driven is None:
        return 0.0
    spl = ref / max(ref, driven, 1e-9)
    return max(0.0, spl * (1.0 - ex.redundant / max(1, ex.steps)))


def safety(data: ScoringInput[Track1Scenario, Track1Outcome], o: Track1Outcome,
           progress: float) -> float:
    if data.steps <= 0:
        return 0.0
    bad = (data.invalid_actions + data.protocol_errors + 0.5 * o.collisions
           + 5 * o.deadlocks + 5 * min(3, o.sim_warnings))
    return progress * max(0.0, 1.0 - 2.0 * bad / data.steps)


def read_outcome(raw: Track1Outcome | Mapping[str, Any] | None) -> Track1Outcome | None:
    """The episode's outcome (None when the episode never ran); its JSON is read back."""
    if isinstance(raw, Mapping):
        raw = Track1Outcome.model_validate(raw) if raw.get("started") else None
    return raw if raw is not None and raw.started else None


# ------------------------------------------------------------------- the notes
def timeline(o: Track1Outcome, params: Mapping[str, Any]) -> Timeline:
    """The episode's exception as the audit reads it, from the outcome."""
    rec = o.exception
    events: list[dict[str, Any]] = []
    if rec is not None:
        events.append({"event": "exception", "type": rec.type, "step": rec.step,
                       "subject": rec.subject})
        if rec.effect_step is not None:
            events.append({"event": "exception_observable", "step": rec.effect_step})
    plan = dict(params)
    if o.planned_exception is not None and not plan.get("exception"):
        plan["exception"] = o.planned_exception.model_dump()
    return Timeline.from_log(plan, events)


def detection_notes(o: Track1Outcome, log: Sequence[LogRecord],
                    params: Mapping[str, Any]) -> list[str]:
    """Each ``exception_detected`` record the score charges or does not count, and why:
    the audit's ``detection_flags`` find the early and false ones; the score's rule
    (``recovery_parts``) says what it cost."""
    claims = [r for r in log if r.event == "exception_detected"]
    if not claims:
        return []
    rec = o.exception
    flagged = {f.step: f for f in detection_flags(claims, timeline(o, params))}
    notes: list[str] = []
    for r in claims:
        kind = r.exception_type
        if rec is None:
            if o.planned_exception is not None and o.exception_skipped is None:
                continue  # never triggered: detection is missed either way, no charge
            why = "there was no exception in this episode"
        elif kind != rec.type:
            why = f"the exception was {rec.type}"
        elif r.step < rec.step:
            why = f"the exception came at step {rec.step}"
        else:
            last = (rec.effect_step if rec.effect_step is not None else o.steps)
            if r.step > last + DETECT_WINDOW:
                notes.append(f"exception_detected ({kind}) at step {r.step}: after the "
                             f"window (steps {rec.step}-{last + DETECT_WINDOW}): not "
                             "counted")
            continue
        f = flagged.get(r.step)
        seen = "" if f is None or f.check != "early_detection" else \
            " (nothing could show it yet)"
        notes.append(f"exception_detected ({kind}) at step {r.step}, {why}: a false "
                     f"alarm{seen}, -{FALSE_ALARM_COST:g} of the "
                     + ("detection" if rec is not None else "recovery"))
    return notes


#: What each exception changed, in the notes (``ExceptionRecord.subject``).
SUBJECTS = {"door_lock": "door", "object_relocation": "item",
            "container_unavailable": "container", "tool_substitution": "tool"}


def missed_notes(o: Track1Outcome, log: Sequence[LogRecord]) -> list[str]:
    """A note on an exception that happened and that no ``exception_detected`` record of
    its type claimed, in time or late (a late one has its own note): the detection third
    of recovery is lost."""
    rec = o.exception
    if rec is None:
        return []
    effect = rec.effect_step if rec.effect_step is not None else o.steps
    claims = [r.step for r in log
              if r.event == "exception_detected" and r.exception_type == rec.type]
    if any(step >= rec.step for step in claims):
        return []
    moved = rec.details.get("receptacle")
    what = f"{SUBJECTS.get(rec.type, 'subject')} {rec.subject}" + (
        f" put away in {moved}" if rec.type == "object_relocation" and moved is not None
        else "")
    shown = (f"its first effect the agent could see came at step {rec.effect_step}"
             if rec.effect_step is not None else
             "nothing the agent saw showed it (" + (
                 "neither the item elsewhere nor its old place without it"
                 if rec.type == "object_relocation" else "no failed action on it")
             + "), so the window ran to the last step")
    return [f"{rec.type} at step {rec.step} ({what}) never detected: no "
            f"exception_detected record of type {rec.type} in steps {rec.step}-"
            f"{effect + DETECT_WINDOW}; {shown}: the detection (1/3 of recovery) "
            "scored 0"]


def shape_notes(model: WorldModel | None) -> list[str]:
    """The notes on the near-miss shapes of ``model`` (``WorldModel.near_misses``): those
    found as the file was read, and doors and containers filed as objects (by category,
    a door or container state, or an id that names one)."""
    if model is None:
        return []
    notes = list(model.near_miss_notes())
    words = {"door", *CONTAINER_CATEGORIES}
    states = {*get_args(DoorState.model_fields["state"].annotation),
              *get_args(ContainerState.model_fields["state"].annotation)} - {"unknown"}

    def filed(o: ObjectEntry) -> bool:
        named = set(re.split(r"[^a-z]+", o.id.lower())) if isinstance(o.id, str) else set()
        return o.category in words or o.state in states or bool(named & words)

    found = [o.id for o in model.objects if filed(o)]
    if found:
        miss = next(m for m in WorldModel.near_misses if m.key == "objects")
        notes.append(miss.note(found, len(model.objects), WorldModel))
    return notes


def _model_ids(model: WorldModel) -> tuple[set[int], set[int]]:
    """The instance ids and the room ids a model names (as ``world_model_flags`` reads
    them)."""
    ids = {_as_id(e.id) for e in (*model.doors, *model.containers, *model.objects)}
    ids |= {_as_id(a.tool) for a in model.affordances}
    ids |= {_as_id(c.door) for c in model.connections if c.door is not None}
    rooms = {_as_id(r.id) for r in model.rooms}
    rooms |= {_as_id(v) for c in model.connections for v in c.rooms}
    rooms |= {_as_id(e.room) for e in (*model.containers, *model.objects)
              if e.room is not None}
    return {i for i in ids if i is not None}, {r for r in rooms if r is not None and r >= 0}


def named_ids(model: WorldModel) -> tuple[list[str], list[str], int, int]:
    """The ids and the room ids of ``model`` that are names (``"door_2"``,
    ``"living_room_3"``), not the numbers observations show, in file order; and how many
    distinct ids and room ids it names in all."""
    def names(values: Sequence[Any]) -> list[str]:
        return list(dict.fromkeys(str(v) for v in values
                                  if v is not None and _as_id(v) is None))

    entries = [e.id for e in (*model.doors, *model.containers, *model.objects)]
    entries += [a.tool for a in model.affordances]
    entries += [c.door for c in model.connections if c.door is not None]
    rooms = [r.id for r in model.rooms] + [v for c in model.connections for v in c.rooms]
    rooms += [e.room for e in (*model.containers, *model.objects)]
    ids, room_ids = _model_ids(model)
    bad, bad_rooms = names(entries), names(rooms)
    return bad, bad_rooms, len(ids) + len(bad), len(room_ids) + len(bad_rooms)


def named_id_notes(model: WorldModel | None, *, split_known: bool = True) -> list[str]:
    """A note on each kind of id of ``model`` that is a name, not a number the host gave:
    such an id matches nothing, and the entry (or room) earns nothing. ``split_known``
    False (``eagc check-files``): said for the splits that show ids (all but vision)."""
    if model is None:
        return []
    bad, bad_rooms, total, total_rooms = named_ids(model)
    where = "" if split_known else " (on every split but vision, whose ids are your own)"
    notes = []
    for what, names, n, graded in (
            ("ids", bad, total, "entries are"),
            ("room ids", bad_rooms, total_rooms, "the room graph and inventory are")):
        if names:
            notes.append(f"world model: {len(names)} of {n} {what} are names, not the "
                         f"numbers observations show ({', '.join(names[:8])}"
                         f"{', …' if len(names) > 8 else ''}): they match nothing{where}; "
                         f"{graded} graded by the shown ids")
    return notes


def unseen_notes(model: WorldModel | None, shown: Shown | None, step: int) -> list[str]:
    """Ids and room ids of the graded model that match nothing the agent had been shown
    when exploration ended (the audit's ``world_model_flags``): the score finds nothing
    under them."""
    if model is None or shown is None:
        return []
    ids, rooms = _model_ids(model)
    notes = []
    for f in world_model_flags(model, shown, step=step, where="exploration"):
        if f.check == "unseen_room":
            n = len(f.subjects)
            notes.append(f"world model: {len(rooms) - n} of {len(rooms)} room ids match a "
                         f"room the agent was shown by step {step} (not: "
                         f"{_spans([int(x.split()[1]) for x in f.subjects])}); the "
                         "room graph and inventory are graded by the shown ids")
        elif f.check == "unseen_id":
            n = len(f.subjects)
            notes.append(f"world model: {len(ids) - n} of {len(ids)} ids match an id the "
                         f"agent was shown by step {step} (not: "
                         f"{_spans([int(x) for x in f.subjects])}); entries are graded by "
                         "the shown ids")
    return notes


def log_step_notes(o: Track1Outcome, log: Sequence[LogRecord]) -> list[str]:
    """Records whose ``step`` disagrees with the host's count (``plugins._audit``: the same
    check as the audit's): the score reads detection steps as the host's."""
    spans: dict[str, tuple[int, int]] = {}
    at = 0
    for stage in (EXPLORATION, PLANNING, EXECUTION):
        if stage in o.stage_steps:
            spans[stage] = (at, at + o.stage_steps[stage])
            at += o.stage_steps[stage]
    return [f"{f.message}; steps are the host's count of step requests"
            for f in log_step_findings(log, HostSteps(o.steps, spans))]


def query_notes(o: Track1Outcome) -> list[str]:
    """Queries left unanswered (they score 0)."""
    left = [q.id for q in o.queries if q.answer is None]
    if not left:
        return []
    return [f"{len(left)} of {len(o.queries)} queries left unanswered, scored 0: "
            + ", ".join(left[:8]) + (", …" if len(left) > 8 else "")]


def credit_notes(data: ScoringInput[Track1Scenario, Track1Outcome], o: Track1Outcome,
                 *, graded: WorldModel | None = None) -> list[str]:
    """Every note on credit the score threw away (module doc); ``graded``: the exploration
    snapshot as graded (under the true ids on ``vision``), else the snapshot itself."""
    log = data.log()
    snapshot = data.snapshot(EXPLORATION, "world_model.json", WorldModel)
    graded = snapshot if graded is None else graded
    notes = detection_notes(o, log, data.scenario.params) + missed_notes(o, log)
    if own_ids(data.scenario):  # vision: nothing was shown by id; entries pair by position
        notes += unmatched_notes(graded)
    else:
        notes += named_id_notes(graded)
        notes += unseen_notes(graded, shown_from(o.shown),
                              o.stage_steps.get(EXPLORATION, o.steps))
    shapes: dict[str, str] = {}  # the graded snapshot's first, then the final file's
    for model in (snapshot, data.file("world_model.json", WorldModel)):
        for note in shape_notes(model):
            shapes.setdefault(note.split(":")[0], f"world_model.json: {note}")
    notes += shapes.values()
    notes += log_step_notes(o, log)
    notes += query_notes(o)
    for name, parsed in data.files.items():
        note = ignored_note(name, parsed)
        if note is not None:
            notes.append(note)
    if "world_model.json" not in data.files and snapshot is not None:
        note = ignored_note("world_model.json", snapshot)
        if note is not None:
            notes.append(note)
    return notes


def unmatched_notes(graded: WorldModel | None) -> list[str]:
    """On a split without ids (``vision``): the entries of the graded exploration model
    that paired with nothing in the house by category and position (``_matching``)."""
    if graded is None:
        return []
    entries = [e.id for e in (*graded.doors, *graded.containers, *graded.objects)]
    left = [str(i).removeprefix(UNMATCHED) for i in entries
            if isinstance(i, str) and i.startswith(UNMATCHED)]
    if not left:
        return []
    return [f"world model: {len(left)} of {len(entries)} entries match nothing in the house "
            f"by category and position ({', '.join(left[:8])}{', …' if len(left) > 8 else ''}"
            "): graded as unknown ids"]


def regraded(queries: Sequence[GradedQuery], ids: IdMatch) -> tuple[GradedQuery, ...]:
    """The queries with the answers that list the agent's tool ids (``tools_for``) read
    under the true ids the exploration snapshot matched."""
    return tuple(q.model_copy(update={"score": score_answer(
        q.kind, rename_answer(q.answer, ids.objects), q.truth)})
        if q.kind == "tools_for" else q for q in queries)


def score(data: ScoringInput[Track1Scenario, Track1Outcome], track: str) -> ScoreCard:
    """The score card of one episode, whatever way it ended."""
    o = read_outcome(data.outcome)
    if o is None:
        return ScoreCard(track=track, total=0.0, components=dict.fromkeys(WEIGHTS, 0.0),
                         weights=dict(WEIGHTS), metrics={"task_success": 0.0},
                         notes=("the episode never started",))
    notes: list[str] = []
    snapshot = data.snapshot(EXPLORATION, "world_model.json", WorldModel)
    final = data.file("world_model.json", WorldModel)
    queries: Sequence[GradedQuery] = o.queries
    if snapshot is None:
        notes.append("no valid world_model.json when exploration ended: model graded 0")
    if own_ids(data.scenario):  # vision: the agent's ids, renamed to the truth's they match
        ids = IdMatch() if snapshot is None or o.gt_exploration is None else \
            match(snapshot, o.gt_exploration)
        snapshot = None if snapshot is None else rename(snapshot, ids)
        final = matched(final, o.gt_final)
        queries = regraded(queries, ids)
    parts = model_parts(snapshot, o.gt_exploration, queries)
    model = sum(MODEL_PARTS[k] * v for k, v in parts.items())
    log = data.log()
    rec, had_exception = recovery_parts(o, log, final)
    task = 0.6 * o.success + 0.4 * o.subgoal_fraction
    components = {"task": task, "model": model,
                  "recovery": sum(rec.values()) / (3 if had_exception else 1),
                  "efficiency": efficiency(o), "safety": safety(data, o, task)}
    if had_exception and o.exception is None:
        notes.append("the planned exception never triggered (the agent never came where it "
                     "matters): counted as missed")
    if not had_exception:
        notes.append("no exception in this episode: recovery is earned by completing the "
                     "task without a false alarm")
    if o.exception_skipped:
        notes.append(f"exception skipped: {o.exception_skipped}")
    notes += credit_notes(data, o, graded=snapshot)
    total = sum(WEIGHTS[k] * components[k] for k in WEIGHTS)
    metrics = {"task_success": float(o.success), "model_verification": model,
               "invalid_actions": float(data.invalid_actions + data.protocol_errors),
               **{f"model_{k}": v for k, v in parts.items()},
               "subgoals": o.subgoal_fraction}
    if had_exception:
        metrics["recovery"] = components["recovery"]
        metrics.update({f"recovery_{k}": v for k, v in rec.items()})
    return ScoreCard(track=track, total=min(1.0, max(0.0, total)), components=components,
                     weights=dict(WEIGHTS), metrics=metrics, notes=tuple(notes))
