"""Track 1's score, equation (1): ``0.40 task + 0.20 model + 0.20 recovery + 0.10 efficiency
+ 0.10 safety``, each component in [0, 1] (DESIGN §5).

- task: 0.6 × main objective (holds at the end) + 0.4 × fraction of key subgoals reached.
- model: the ``world_model.json`` snapshot taken when exploration ended, against the ground
  truth at that moment: room-graph edge F1 (0.25), object inventory F1 by category and room
  with the position within ``POSITION_TOLERANCE`` (0.25), door and container state accuracy
  (0.15), (tool, affordance) F1 (0.10), and the query answers (0.25).
- recovery (episodes with an exception): a third each for detecting it (an
  ``exception_detected`` log record of the right type from the moment it happened until
  ``DETECT_WINDOW`` steps after its first observable effect; each false alarm, a record of
  another type or before it happened, takes a quarter off), updating the final model (the
  door locked, the object in its new room, the container unavailable, or a substitute tool
  listed and the missing one not), and completing the task by a valid alternative. An
  exception that was planned but never triggered (the agent never came where it matters)
  counts as missed. Without an exception the weight is spread over the others in proportion.
- efficiency: SPL over execution (reference length from ``_paths`` through the poses where
  the agent started, picked, met the exception and succeeded, over the path it drove until
  success) × (1 − the fraction of redundant execution actions: noops, failed actions, moves
  that went nowhere).
- safety: ``1 − 2 × bad / steps`` (floor 0), where bad counts invalid actions and protocol
  errors, half of each collision, and 5 per deadlock (30 steps without progress) and per
  MuJoCo warning (at most 3).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from plugins._base import ScoringInput
from plugins.track1._queries import f1
from schemas import LogRecord, ScoreCard, WorldModel

WEIGHTS = {"task": 0.40, "model": 0.20, "recovery": 0.20, "efficiency": 0.10, "safety": 0.10}
MODEL_PARTS = {"topology": 0.25, "objects": 0.25, "states": 0.15, "affordances": 0.10,
               "queries": 0.25}
POSITION_TOLERANCE = 0.5
DETECT_WINDOW = 30
FALSE_ALARM_COST = 0.25


def _key(value: Any) -> Any:
    """Ids as the agent may write them (``3`` or ``"3"``) compare equal."""
    if isinstance(value, str) and value.strip().lstrip("-").isdigit():
        return int(value)
    return value


def topology(model: WorldModel, gt: Mapping[str, Any]) -> float:
    """F1 of the room graph's edges (room pairs)."""
    truth = {frozenset(e["rooms"]) for e in gt["edges"]}
    given = {frozenset(_key(r) for r in c.rooms) for c in model.connections}
    return f1({g for g in given if len(g) == 2}, truth)


def inventory(model: WorldModel, gt: Mapping[str, Any]) -> float:
    """F1 of the object inventory: same category and room, position within tolerance."""
    truth = [(o["category"], o["room"], o["position"][:2]) for o in gt["objects"]]
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


def states(model: WorldModel, gt: Mapping[str, Any]) -> float:
    """Accuracy of the door and container states (a missing entry is wrong)."""
    doors = {_key(d.id): d.state for d in model.doors}
    boxes = {_key(c.id): c.state for c in model.containers}
    truth = [(doors, d["id"], d["state"]) for d in gt["doors"]]
    truth += [(boxes, c["id"], c["state"]) for c in gt["containers"]]
    if not truth:
        return 1.0
    return sum(table.get(i) == s for table, i, s in truth) / len(truth)


def affordances(model: WorldModel, gt: Mapping[str, Any]) -> float:
    """F1 of (tool id, affordance) pairs of the available tools."""
    truth = {(t["id"], a) for t in gt["tools"] if t["available"] for a in t["affordances"]}
    return f1({(_key(a.tool), a.affordance) for a in model.affordances}, truth)


def model_parts(model: WorldModel | None, gt: Mapping[str, Any] | None,
                queries: Sequence[Mapping[str, Any]]) -> dict[str, float]:
    """The parts of the model score (each in [0, 1])."""
    parts = {"queries": sum(q["score"] for q in queries) / len(queries) if queries else 0.0}
    for name, fn in (("topology", topology), ("objects", inventory), ("states", states),
                     ("affordances", affordances)):
        parts[name] = 0.0 if model is None or gt is None else fn(model, gt)
    return parts


def _updated(kind: str, exc: Mapping[str, Any], model: WorldModel | None,
             gt: Mapping[str, Any]) -> bool:
    if model is None:
        return False
    subject = exc["subject"]
    if kind == "door_lock":
        return any(_key(d.id) == subject and d.state == "locked" for d in model.doors)
    if kind == "container_unavailable":
        return any(_key(c.id) == subject and c.state == "unavailable" for c in model.containers)
    if kind == "object_relocation":
        room = next((o["room"] for o in gt["objects"] if o["id"] == subject), None)
        return any(_key(o.id) == subject and _key(o.room) == room for o in model.objects)
    tool = next((t for t in gt["tools"] if t["id"] == subject), None)
    if tool is None:
        return False
    listed = {_key(a.tool) for a in model.affordances if a.affordance in tool["affordances"]}
    present = any(_key(o.id) == subject and o.state not in ("removed", "unavailable", "missing")
                  for o in model.objects)
    substitutes = {t["id"] for t in gt["tools"] if t["available"]
                   and set(t["affordances"]) & set(tool["affordances"])}
    return bool(listed & substitutes) and subject not in listed and not present


def recovery_parts(outcome: Mapping[str, Any], log: Iterable[LogRecord],
                   model: WorldModel | None) -> dict[str, float] | None:
    """Detection, model update and completion, or None when there was no exception."""
    exc = outcome.get("exception")
    success = float(bool(outcome.get("success")))
    if exc is None:
        if outcome.get("planned_exception") and not outcome.get("exception_skipped"):
            return {"detected": 0.0, "updated": 0.0, "completed": success}
        return None
    kind = exc["type"]
    last = (exc["effect_step"] if exc["effect_step"] is not None
            else outcome.get("steps", exc["step"])) + DETECT_WINDOW
    claims = [r for r in log if r.event == "exception_detected"]
    hit = any(r.exception_type == kind and exc["step"] <= r.step <= last for r in claims)
    false = sum(1 for r in claims if r.exception_type != kind or r.step < exc["step"])
    gt = outcome.get("gt_final") or {}
    return {
        "detected": float(hit) * max(0.0, 1.0 - FALSE_ALARM_COST * false),
        "updated": float(bool(gt) and _updated(kind, exc, model, gt)),
        "completed": success,
    }


def efficiency(outcome: Mapping[str, Any]) -> float:
    ex = outcome.get("execution") or {}
    ref, driven = ex.get("reference_length"), ex.get("path_at_success")
    if not outcome.get("success") or ref is None or driven is None:
        return 0.0
    spl = ref / max(ref, driven, 1e-9)
    redundant = ex.get("redundant", 0) / max(1, ex.get("steps", 0))
    return max(0.0, spl * (1.0 - redundant))


def safety(data: ScoringInput) -> float:
    o = data.outcome
    if data.steps <= 0:
        return 0.0
    bad = (data.invalid_actions + data.protocol_errors + 0.5 * o.get("collisions", 0)
           + 5 * o.get("deadlocks", 0) + 5 * min(3, o.get("sim_warnings", 0)))
    return max(0.0, 1.0 - 2.0 * bad / data.steps)


def score(data: ScoringInput, track: str) -> ScoreCard:
    """The score card of one episode, whatever way it ended."""
    o = data.outcome
    notes: list[str] = []
    success = bool(o.get("success"))
    goals = o.get("subgoals") or {}
    reached = sum(v is not None for v in goals.values()) / len(goals) if goals else 0.0
    snapshot = data.snapshots.get("exploration", {}).get("world_model.json")
    if snapshot is None:
        notes.append("no valid world_model.json when exploration ended: model graded 0")
    parts = model_parts(snapshot, o.get("gt_exploration"), o.get("queries") or [])
    model = sum(MODEL_PARTS[k] * v for k, v in parts.items())
    log = data.files.get("episode_log.jsonl") or []
    rec = recovery_parts(o, log, data.files.get("world_model.json"))
    components = {"task": 0.6 * success + 0.4 * reached, "model": model,
                  "efficiency": efficiency(o), "safety": safety(data)}
    weights = dict(WEIGHTS)
    if rec is None:
        w = weights.pop("recovery")
        rest = sum(weights.values())
        weights = {k: v + w * v / rest for k, v in weights.items()}
        notes.append("no exception in this episode: recovery weight redistributed")
    else:
        components["recovery"] = sum(rec.values()) / 3
        if o.get("exception") is None:
            notes.append("the planned exception never triggered (the agent never came where "
                          "it matters): counted as missed")
    if o.get("exception_skipped"):
        notes.append(f"exception skipped: {o['exception_skipped']}")
    total = sum(weights[k] * components[k] for k in weights)
    metrics = {"task_success": float(success), "model_verification": model,
               "invalid_actions": float(data.invalid_actions + data.protocol_errors),
               **{f"model_{k}": v for k, v in parts.items()},
               "subgoals": reached}
    if rec is not None:
        metrics["recovery"] = components["recovery"]
        metrics.update({f"recovery_{k}": v for k, v in rec.items()})
    return ScoreCard(track=track, total=min(1.0, max(0.0, total)), components=components,
                     weights=weights, metrics=metrics, notes=tuple(notes))
