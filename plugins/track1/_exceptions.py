"""The controlled exception of Table III: the one owner of its state, trigger and effect.

At most one per episode, planned by the scenario against one goal, applied where it
matters, and only if the task stays completable: before an exception is applied for good
the environment must still offer a recoverable path for every goal
(``HouseEnv.has_recoverable_path``), with room for the place goals together
(``LiveEpisode.recoverable``); otherwise the world is rolled back and the exception is
skipped with a reason.

When it happens (official splits, where exceptions show only through their effects):

- ``door_lock``: the first door of the agent's submitted route (``doors``, else ``route``,
  else the shortest path through the task's rooms) that is farther than ``TRIGGER_DIST``
  when execution starts locks when the robot comes within ``TRIGGER_DIST`` of it. It looks
  closed until ``open`` fails with ``locked``.
- ``object_relocation``: at the step the robot enters the room of the goal's object or
  comes within ``TRIGGER_DIST`` of it, before that step's observation, the object is put
  away at one of the backup places (``_budgets.backup_places``: storage room furniture,
  cabinets and drawers elsewhere, a container shut after; a shelf elsewhere only when none
  of those has room; never in its room nor the robot's), out of view or into a closed
  container, drawn from the scenario's seed.
- ``container_unavailable``: when the robot, holding the goal's object, comes within
  ``TRIGGER_DIST`` of the named container, the container stops working: it looks as before
  and ``open``/``place`` on it fail with ``unavailable``.
- ``tool_substitution``: as execution starts the named tool is taken away.

On the dev split exceptions show themselves (a locked door shows ``locked``, an unavailable
container ``unavailable``) and relocation and tool removal happen as execution starts (the
object goes to the storage room).

An exception applied during a step shows in that step's observation. The first observable
effect (for the detection window of the recovery score): an action on the subject fails;
or, for a door that was open, the agent sees it closed; for a moved or removed item, the
agent sees the item elsewhere or its old place, within ``EFFECT_RADIUS``, without it. On
the dev split, seeing the subject at all counts.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from plugins.track1._budgets import backup_places
from plugins.track1._types import ExceptionRecord, PlannedException, Task, Track1Plan

if TYPE_CHECKING:
    from simhost.worlds.track1 import ActionResult, HouseEnv


class LiveEpisode(Protocol):
    """What an exception reads and changes of the live episode (``Track1Episode``)."""

    env: HouseEnv
    task: Task
    plan: Track1Plan | None
    steps: int

    @property
    def house(self) -> Any:
        """The simulated house."""

    def perceived_ids(self) -> set[int]:
        """Ids in the agent's detections at this step."""

    def recoverable(self) -> bool:
        """Whether every goal can still be completed from where the robot is."""

TRIGGER_DIST = 3.0
EFFECT_RADIUS = 2.5

Event = Mapping[str, Any]


class ControlledException:
    """The episode's exception: planned, armed, applied (or skipped), then observed."""

    def __init__(self, plan: PlannedException | None, task: Task, seed: int, *,
                 hidden: bool) -> None:
        self.plan = plan
        self.goal = task.goals[plan.goal] if plan is not None else None
        self.hidden = hidden
        self.seed = seed
        self.subject: int | None = None
        self.armed = False
        self.record: ExceptionRecord | None = None
        self.skipped: str | None = None

    # ---------------------------------------------------------------- triggers
    def start_execution(self, ep: LiveEpisode) -> list[Event]:
        """Picks the subject; applies what happens as execution starts."""
        if self.plan is None or self.goal is None:
            return []
        kind, g, env = self.plan.type, self.goal, ep.env
        if kind == "door_lock":
            doors = route_doors(ep)
            if not doors:
                return self._skip("door_lock: the route crosses no door")
            x, y, _ = ep.house.robot_pose
            far = [d for d in doors
                   if math.dist(env.layout.entity(d).centre, (x, y)) > TRIGGER_DIST + 0.5]
            self.subject, self.armed = (far or doors)[0], True
            return [{"event": "exception_armed", "type": kind, "door": self.subject,
                     "route_doors": doors}]
        if kind == "container_unavailable":
            self.subject, self.armed = g.receptacle, True
            return [{"event": "exception_armed", "type": kind, "container": self.subject}]
        self.subject = g.fetched
        if kind == "tool_substitution":
            return self._apply(ep, lambda: env.remove_tool(g.fetched))
        if not self.hidden:
            return self._apply(ep, lambda: env.relocate_object(g.fetched))
        self.armed = True
        return [{"event": "exception_armed", "type": kind, "subject": self.subject},
                *self._trigger(ep)]

    def on_step(self, ep: LiveEpisode, action: Mapping[str, Any],
                result: ActionResult) -> list[Event]:
        """Triggers an armed exception where it matters; notes its first observable effect."""
        if self.armed:
            return self._trigger(ep)
        rec = self.record
        if rec is None or rec.effect_step is not None:
            return []
        if self._observable(ep, action, result):
            self.record = rec.model_copy(update={"effect_step": ep.steps})
            return [{"event": "exception_observable", "type": rec.type, "step": ep.steps}]
        return []

    def _trigger(self, ep: LiveEpisode) -> list[Event]:
        assert self.plan is not None and self.goal is not None and self.subject is not None
        env, house, subject = ep.env, ep.house, self.subject
        x, y, _ = house.robot_pose
        kind = self.plan.type
        if kind == "door_lock":
            if math.dist(env.layout.entity(subject).centre, (x, y)) <= TRIGGER_DIST:
                return self._apply(ep, lambda: env.lock_door(subject))
            return []
        if kind == "container_unavailable":
            f = env.layout.entity(subject)
            if house.world.held == self.goal.object and math.dist(f.pos, (x, y)) <= TRIGGER_DIST:
                return self._apply(ep, lambda: env.make_container_unavailable(subject))
            return []
        if house.world.held == subject:
            return []  # in the robot's hand: it cannot vanish any more
        if kind == "tool_substitution":
            return self._apply(ep, lambda: env.remove_tool(subject))
        truth = env.ground_truth()
        obj = truth.object(subject)
        assert obj is not None
        here = house.robot_room
        if here != obj.room and math.dist(obj.position[:2], (x, y)) > TRIGGER_DIST:
            return []
        in_view = {d.id for d in house.visible()}
        ends = {x for g in ep.task.goals for x in (g.destination, *g.substitutes)}
        rng = np.random.default_rng([self.seed, 2, ep.steps])
        for tier in backup_places(truth, (obj.room, here), ends):
            # out of view, or shut already (what goes into a closed container is not seen)
            places = [p for p in tier if p not in in_view
                      or house.world.containers.get(p) == "closed"]
            for k in rng.permutation(len(places)).tolist():
                events = self._apply(ep, lambda p=places[k]: env.relocate_object(
                    subject, receptacle=p, shut=True), quiet=True)
                if events:
                    return events
        return self._skip(f"object_relocation: no backup place for item {subject}")

    # ---------------------------------------------------------------- applying
    def _skip(self, reason: str) -> list[Event]:
        self.skipped, self.armed = reason, False
        assert self.plan is not None
        return [{"event": "exception_skipped", "type": self.plan.type, "reason": reason}]

    def _apply(self, ep: LiveEpisode, change: Callable[[], dict[str, Any]], *,
               quiet: bool = False) -> list[Event]:
        """Applies a change if every goal stays completable; records the exception."""
        from simhost.worlds.track1 import PerturbationError

        assert self.plan is not None and self.subject is not None
        env = ep.env
        before = env.get_state()
        try:
            details = change()
        except PerturbationError as e:
            if "stands in doorway" in str(e) or quiet:
                return []  # try again at the next step (or another place)
            return self._skip(f"{self.plan.type}: {e}")
        if not ep.recoverable():
            env.set_state(before)
            if quiet:
                return []
            return self._skip(f"{self.plan.type}: it would leave no recoverable path")
        x, y, _ = ep.house.robot_pose
        self.armed = False
        self.record = ExceptionRecord(type=self.plan.type, goal=self.plan.goal,
                                      subject=self.subject, step=ep.steps, pose=(x, y),
                                      details=details)
        return [{"event": "exception", **self.record.model_dump(mode="json")}]

    # ---------------------------------------------------------------- observing
    def _observable(self, ep: LiveEpisode, action: Mapping[str, Any],
                    result: ActionResult) -> bool:
        """Whether the agent could notice the exception in this step's observation or
        result."""
        rec = self.record
        assert rec is not None
        seen = ep.perceived_ids()
        hit = int(action.get("target", -1)) == rec.subject and not result.ok
        if hit or (not self.hidden and rec.subject in seen):
            return True
        if rec.type == "door_lock":
            return rec.details.get("previous") == "open" and rec.subject in seen
        if rec.type == "container_unavailable":
            return False
        if rec.subject in seen:
            return True
        old = int(rec.details["previous_receptacle"])
        f = ep.env.layout.entity(old)
        x, y, _ = ep.house.robot_pose
        if old not in seen or math.dist(f.pos, (x, y)) > EFFECT_RADIUS:
            return False
        return f.kind != "container" or ep.house.world.containers[old] == "open"


def route_doors(ep: LiveEpisode) -> list[int]:
    """Doors of the agent's route, else of the shortest path through the task's rooms. On a
    split without a detector (``vision``) the plan's door ids are the agent's own: the doors
    are those between the route's rooms (room ids are shown)."""
    house, layout = ep.house, ep.env.layout
    plan = ep.plan or Track1Plan()
    door_ids = {d.id for d in layout.doors} if ep.env.config.detections else set()
    doors = [d for d in plan.doors if d in door_ids]
    if not doors and plan.route:
        pairs = {frozenset(d.rooms): d.id for d in reversed(layout.doors)}
        doors = [pairs[frozenset((a, b))] for a, b in zip(plan.route, plan.route[1:],
                                                          strict=False)
                 if frozenset((a, b)) in pairs]
    if doors:
        return doors
    truth = ep.env.ground_truth()
    rooms = [house.robot_room]
    for g in ep.task.goals:
        for entity in (g.fetched, g.destination):
            obj, rec = truth.object(entity), truth.receptacle(entity)
            rooms.append(obj.room if obj is not None else rec.room if rec is not None else -1)
    rooms = [r for r in rooms if r >= 0]
    path: list[int] = [rooms[0]]
    for a, b in zip(rooms, rooms[1:], strict=False):
        path += house.shortest_path(a, b)[1:]
    return house.route_doors(path)
