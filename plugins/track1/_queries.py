"""Queries about the agent's model, asked at the start of planning and graded against the
ground truth at the end of exploration ("queryable" model).

The scenario plans the queries (subjects by id); a query is sent only when the agent
detected its subject during exploration (or visited the room), so no id of an undiscovered
thing ever reaches the agent. A query not sent, or not answered, counts as wrong.

Kinds and answers: ``object_room`` (object id → room id), ``door_state`` (door id →
"open" | "closed" | "locked"), ``room_neighbours`` (room id → list of room ids it connects to),
``container_state`` (container id → "open" | "closed" | "unavailable"), ``tools_for``
(affordance → list of tool ids). Lists are graded by F1, the others by equality.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from plugins.track1._episode import Track1Episode

FIELD = {"object_room": "object", "door_state": "door", "room_neighbours": "room",
         "container_state": "container", "tools_for": "affordance"}
TEXT = {
    "object_room": "Which room (id) is object {} in?",
    "door_state": "Is door {} open, closed or locked?",
    "room_neighbours": "Which rooms (ids) does room {} connect to through a doorway?",
    "container_state": "Is container {} open, closed or unavailable?",
    "tools_for": "Which tools (ids) can {}?",
}


def to_send(planned: Sequence[Mapping[str, Any]], ep: Track1Episode) -> list[dict[str, Any]]:
    """The planned queries whose subject the agent discovered, as the agent sees them."""
    out = []
    for q in planned:
        kind, subject = q["kind"], q["subject"]
        known = (kind == "tools_for" or (kind == "room_neighbours" and subject in ep.visited)
                 or (kind != "room_neighbours" and subject in ep.seen))
        if known:
            out.append({"id": q["id"], "kind": kind, FIELD[kind]: subject,
                        "text": TEXT[kind].format(subject)})
    return out


def truth_of(kind: str, subject: Any, gt: Mapping[str, Any]) -> Any:
    """The right answer in a ground-truth dict."""
    if kind == "object_room":
        return next((o["room"] for o in gt["objects"] if o["id"] == subject), None)
    if kind == "door_state":
        return next((d["state"] for d in gt["doors"] if d["id"] == subject), None)
    if kind == "container_state":
        return next((c["state"] for c in gt["containers"] if c["id"] == subject), None)
    if kind == "room_neighbours":
        return sorted({b for e in gt["edges"] for a, b in (e["rooms"], e["rooms"][::-1])
                       if a == subject})
    return sorted(gt["affordances"].get(subject, []))


def _int(value: Any) -> int | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value
    if isinstance(value, str) and value.strip().lstrip("-").isdigit():
        return int(value)
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return None


def f1(predicted: Iterable[Any], truth: Iterable[Any]) -> float:
    """F1 of two sets (1 when both are empty)."""
    p, t = set(predicted), set(truth)
    if not p and not t:
        return 1.0
    hits = len(p & t)
    return 0.0 if hits == 0 else 2 * hits / (len(p) + len(t))


def score_answer(kind: str, answer: Any, truth: Any) -> float:
    """One answer's score in [0, 1]."""
    if answer is None or truth is None:
        return 0.0
    if kind in ("room_neighbours", "tools_for"):
        if not isinstance(answer, list):
            return 0.0
        ids = [_int(a) for a in answer]
        return f1((i for i in ids if i is not None), truth)
    if kind == "object_room":
        return float(_int(answer) == truth)
    return float(isinstance(answer, str) and answer.strip().lower() == truth)


def grade(planned: Sequence[Mapping[str, Any]], ep: Track1Episode) -> list[dict[str, Any]]:
    """Every planned query with whether it was sent, the truth, the answer and its score."""
    sent = {q["id"] for q in ep.queries_sent}
    out = []
    for q in planned:
        truth = None if ep.gt_exploration is None else truth_of(
            q["kind"], q["subject"], ep.gt_exploration)
        answer = ep.answers.get(q["id"])
        out.append({**q, "sent": q["id"] in sent, "truth": truth, "answer": answer,
                    "score": score_answer(q["kind"], answer, truth) if q["id"] in sent else 0.0})
    return out
