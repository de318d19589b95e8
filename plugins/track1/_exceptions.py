"""The controlled exceptions of Table III: when they trigger and when they become observable.

Each trigger first checks, with the environment's own API, that the task stays completable
(``has_recoverable_path``) after the change; if not, the world is rolled back
(``get_state``/``set_state``) and the exception is skipped with a reason.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from plugins.track1._episode import EFFECT_RADIUS, TRIGGER_DIST

if TYPE_CHECKING:
    from plugins.track1._episode import Track1Episode


class Track1Plan(BaseModel):
    """The plan an agent submits in the ``end_stage`` payload that ends planning."""

    model_config = ConfigDict(extra="ignore")

    subgoals: list[str] = Field(default_factory=list, max_length=100)
    route: list[int] = Field(default_factory=list, max_length=100,
                             description="Room ids in visiting order.")
    doors: list[int] = Field(default_factory=list, max_length=100,
                             description="Door ids in crossing order.")


def parse_plan(payload: Mapping[str, Any]) -> tuple[dict[str, Any] | None, str]:
    """The submitted plan (``payload["plan"]``, or the payload itself) and an error text."""
    raw = payload.get("plan", payload) if isinstance(payload, Mapping) else None
    if not raw:
        return None, "no plan submitted"
    try:
        return Track1Plan.model_validate(raw).model_dump(), ""
    except ValidationError as e:
        return None, f"invalid plan: {e.errors()[0]['msg']}"


def _route_doors(ep: Track1Episode) -> list[int]:
    """Doors of the agent's route, else of the shortest path through the task's rooms."""
    house, layout = ep.env.house, ep.env.layout
    assert house is not None
    plan = ep.plan or {}
    door_ids = {d.id for d in layout.doors}
    doors = [d for d in plan.get("doors", []) if d in door_ids]
    if not doors and plan.get("route"):
        pairs = {frozenset(d.rooms): d.id for d in reversed(layout.doors)}
        route = plan["route"]
        doors = [pairs[frozenset((a, b))] for a, b in zip(route, route[1:], strict=False)
                 if frozenset((a, b)) in pairs]
    if doors:
        return doors
    rooms = [house.robot_room, *_task_rooms(ep)]
    path: list[int] = [rooms[0]]
    for a, b in zip(rooms, rooms[1:], strict=False):
        path += house.shortest_path(a, b)[1:]
    return house.route_doors(path)


def _task_rooms(ep: Track1Episode) -> list[int]:
    truth = ep.env.ground_truth()
    where = {o["id"]: o["room"] for o in truth["objects"]}
    where.update({f["id"]: f["room"] for f in truth["furniture"] + truth["containers"]})
    t = ep.task
    first = t["object"] if t["kind"] == "place" else t["tool"]
    second = t["receptacle"] if t["kind"] == "place" else t["target"]
    return [where[i] for i in (first, second) if i in where]


def _apply(ep: Track1Episode, kind: str, subject: int, change: Callable[[], dict]
           ) -> list[Mapping[str, Any]]:
    """Applies a change if the task stays recoverable; records the exception."""
    from simhost.track1 import PerturbationError

    env = ep.env
    before = env.get_state()
    try:
        details = change()
    except PerturbationError as e:
        if "stands in doorway" in str(e):
            return []  # try again at the next step
        ep.skipped, ep.exc_type = f"{kind}: {e}", None
        return [{"event": "exception_skipped", "type": kind, "reason": str(e)}]
    if not env.has_recoverable_path(ep.house_task()):
        env.set_state(before)
        ep.skipped, ep.exc_type = f"{kind}: it would leave no recoverable path", None
        return [{"event": "exception_skipped", "type": kind, "reason": ep.skipped}]
    house = env.house
    assert house is not None
    x, y, _ = house.robot_pose
    ep.exception = {"type": kind, "subject": subject, "step": ep.steps, "pose": [x, y],
                    "details": details, "effect_step": None}
    ep.exc_type = None
    return [{"event": "exception", **ep.exception}]


def on_execution_start(ep: Track1Episode) -> list[Mapping[str, Any]]:
    """Picks the exception's subject; applies the ones that happen as execution starts."""
    kind, t = ep.exc_type, ep.task
    if kind is None:
        return []
    env = ep.env
    if kind == "door_lock":
        doors = _route_doors(ep)
        if not doors:
            ep.skipped, ep.exc_type = "door_lock: the route crosses no door", None
            return [{"event": "exception_skipped", "type": kind, "reason": ep.skipped}]
        x, y, _ = env.house.robot_pose  # type: ignore[union-attr]
        far = [d for d in doors if math.dist(env.layout.entity(d).centre, (x, y))
               > TRIGGER_DIST + 0.5]
        ep.exc_subject = (far or doors)[0]
        return [{"event": "exception_armed", "type": kind, "door": ep.exc_subject,
                 "route_doors": doors}]
    if kind == "container_unavailable":
        ep.exc_subject = t["receptacle"]
        return [{"event": "exception_armed", "type": kind, "container": ep.exc_subject}]
    if kind == "object_relocation":
        ep.exc_subject = t["object"]
        return _apply(ep, kind, t["object"], lambda: env.relocate_object(t["object"]))
    ep.exc_subject = t["tool"]
    return _apply(ep, kind, t["tool"], lambda: env.remove_tool(t["tool"]))


def on_step(ep: Track1Episode, primitive: str, action: Mapping[str, Any],
            result: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """Triggers an armed exception where it matters; notes its first observable effect."""
    env, house = ep.env, ep.env.house
    assert house is not None
    x, y, _ = house.robot_pose
    kind, subject = ep.exc_type, ep.exc_subject
    if kind == "door_lock" and subject is not None:
        if math.dist(env.layout.entity(subject).centre, (x, y)) <= TRIGGER_DIST:
            return _apply(ep, kind, subject, lambda: env.lock_door(subject))
        return []
    if kind == "container_unavailable" and subject is not None:
        f = env.layout.entity(subject)
        if house.world.held == ep.task["object"] and math.dist(f.pos, (x, y)) <= TRIGGER_DIST:
            return _apply(ep, kind, subject, lambda: env.make_container_unavailable(subject))
        return []
    exc = ep.exception
    if exc is None or exc["effect_step"] is not None:
        return []
    if _observable(ep, exc, action, result):
        exc["effect_step"] = ep.steps
        return [{"event": "exception_observable", "type": exc["type"], "step": ep.steps}]
    return []


def _observable(ep: Track1Episode, exc: Mapping[str, Any], action: Mapping[str, Any],
                result: Mapping[str, Any]) -> bool:
    """Whether the agent could notice the exception in this step's observation or result."""
    subject = exc["subject"]
    seen = {d["id"] for d in ep._info["detections"]}
    hit = int(action.get("target", -1)) == subject and not result["ok"]
    if exc["type"] in ("door_lock", "container_unavailable"):
        return subject in seen or hit
    if subject in seen or hit:
        return True
    # The item's old place is in view: the agent can see that it is gone.
    house = ep.env.house
    assert house is not None
    old = exc["details"]["previous_receptacle"]
    rec = ep.env.layout.entity(old)
    x, y, _ = house.robot_pose
    if old not in seen or math.dist(rec.pos, (x, y)) > EFFECT_RADIUS:
        return False
    return rec.kind != "container" or house.world.container_state(old) == "open"
