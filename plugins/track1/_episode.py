"""``Track1Episode``: one live Track 1 episode around a ``HouseEnv`` (the rules of the game).

Stages: ``exploration`` → ``planning`` (nothing moves: any primitive but ``noop`` is refused
and counts as an invalid action; the plan comes in the ``end_stage`` payload) →
``execution`` (``done`` ends the episode). At the start of planning the agent gets the
instruction and the queries; it answers them with ``answer`` requests during planning.
Each stage's step budget comes from the scenario (``_budgets``).

The task holds when every goal holds (``Goal`` in ``_types``; each goal is checked by the
environment's own ``HouseTask``, with the substitutes accepted once the named container or
tool became unusable). The controlled exception is ``_exceptions.ControlledException``'s.

Observation: every ``HouseEnv`` array as a tensor (int8 flags as uint8); JSON data:
``detections`` (the detection rows as a JSON list), ``room_name`` (the type of ``room``,
empty when ``room`` is -1) and ``action_result``. A split without a detector (``vision``)
leaves out the ``det_*`` tensors, ``detections`` and (when its config says so) the
``segmentation`` image; its actions name what they act on by a pixel of the last frame
(``target_px``, ``tool_px``), which the env resolves through the segmentation it keeps.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from plugins._base import Scenario
from plugins.track1 import _queries
from plugins.track1._budgets import goal_points
from plugins.track1._exceptions import ControlledException
from plugins.track1._paths import Point, reference_length
from plugins.track1._types import (
    ExecutionStats,
    Goal,
    GoalProgress,
    ShownRecord,
    Track1Outcome,
    Track1Plan,
    Track1Scenario,
)
from plugins.track1.audit import Shown
from schemas import ActionResult, EndReason, FieldSpec, HostMessage
from simhost import Observation, Pose, StepOutcome, TrackEpisode
from simhost.worlds.track1 import HouseInfo

EXPLORATION, PLANNING, EXECUTION = "exploration", "planning", "execution"
DEADLOCK_STEPS = 30
DEADLOCK_RADIUS = 0.3

_OBS_TEXT = {
    "odometry": "x, y (m) and yaw (rad, counter-clockwise from +x) of the robot in the house "
    "frame, as its odometry estimates them (official splits: the estimate drifts as the "
    "robot moves)",
    "range_scan": "distances (m) of a planar scan 0.3 m above the floor, rays evenly spaced "
    "counter-clockwise from straight ahead over 360 degrees; no hit reads the scan range",
    "room": "id of the room the robot is in (official splits: only at reset and at the step "
    "it enters a room, read from a sign by the doorway; -1 otherwise)",
    "room_type": "index into the choices of the type of `room`; -1 when `room` is -1",
    "held": "instance id of the held item; -1 when the hand is empty",
    "last_action_ok": "1 when the last primitive succeeded, else 0",
    "collided": "1 when the last move stopped on contact, else 0",
    "det_mask": "1 for the rows that hold a detection (nearest first), 0 for padding rows",
    "det_id": "persistent instance id of each detection (what open/close/pick/place/use "
    "take); -1 in padding rows",
    "det_kind": "index into the choices of the detection's kind; -1 in padding rows",
    "det_category": "index into the choices of the category as reported (official splits: "
    "some things read as a look-alike from afar, every time; right from closer); -1 in "
    "padding rows",
    "det_colour": "index into the choices of the colour as reported (official splits: a "
    "look-alike from afar for some things); 'none' for doors and furniture; -1 in padding "
    "rows",
    "det_state": "index into the choices of the visible state (official splits: a locked "
    "door looks closed, an unavailable container as before); -1 in padding rows",
    "det_rel_pos": "position (m) in the robot frame, x ahead and y to the left (official "
    "splits: noise growing with distance); 0 in padding rows",
    "rgb": "egocentric camera image (RGB)",
    "depth": "egocentric camera depth (m) along the optical axis",
    "segmentation": "instance id seen at each pixel of the camera image; -1 for walls, "
    "floors and the robot",
}


def _action_spec(config: Any = None) -> tuple[FieldSpec, ...]:
    """The action fields; ``config`` (a ``HouseEnvConfig``) with ``actions_by="pixel"``:
    ``target_px``/``tool_px`` instead of the ids."""
    from simhost.worlds.track1 import MAX_IDS, PRIMITIVES

    common = (
        FieldSpec(name="primitive", dtype="int32", choices=PRIMITIVES,
                  description="the primitive, by index or name"),
        FieldSpec(name="move", dtype="float32", shape=(2,), low=-1.0, high=1.0,
                  description="move: [forward, turn]: turn by turn × 45° (counter-clockwise), "
                  "then drive forward × 0.5 m"),
    )
    if config is not None and config.actions_by == "pixel":
        w, h = config.image_size
        where = (f"a pixel [u, v] (column 0..{w - 1} from the left, row 0..{h - 1} from the "
                 "top) of the last camera frame received")
        return (*common,
                FieldSpec(name="target_px", dtype="int32", shape=(2,), low=0.0,
                          high=float(max(w, h) - 1),
                          description=f"open/close/pick/use: the instance acted on, as {where} "
                          "(this split takes no ids); the thing under it must be in view and "
                          "in reach; place: the receptacle. A pixel on no instance (a wall, "
                          "the floor) fails with 'nothing_there'"),
                FieldSpec(name="tool_px", dtype="int32", shape=(2,), low=0.0,
                          high=float(max(w, h) - 1),
                          description=f"use: the held tool, as {where}; absent: the held "
                          "item"))
    return (*common,
            FieldSpec(name="target", dtype="int32", low=0, high=MAX_IDS - 1,
                      description="open/close/pick/use: the instance acted on (it must be in "
                      "view and in reach); place: the receptacle"),
            FieldSpec(name="tool", dtype="int32", low=0, high=MAX_IDS - 1,
                      description="use: the held tool"))


def _observation_spec(env: Any) -> tuple[FieldSpec, ...]:
    from simhost.worlds.track1 import CATEGORIES, COLOURS, KINDS, ROOM_TYPES, STATES

    names = {"room_type": ROOM_TYPES, "det_kind": KINDS, "det_category": CATEGORIES,
             "det_colour": COLOURS, "det_state": STATES}
    out = []
    for name, box in env.observation_space.spaces.items():
        dtype = "uint8" if box.dtype == np.int8 else box.dtype.name
        text = _OBS_TEXT.get(name, "")
        if name == "held" and env.config.held == "flag":
            text = "1 when the hand holds something, else 0 (this split names no ids)"
        if name in names:
            text = text.replace("the choices", "(" + ", ".join(names[name]) + ")")
        out.append(FieldSpec(name=name, dtype=dtype, shape=tuple(box.shape),
                             low=float(np.min(box.low)), high=float(np.max(box.high)),
                             tensor=True, description=text))
    if env.config.detections:
        out.append(FieldSpec(name="detections", dtype="json", description="the detection rows "
                             "as a JSON list of {id, kind, category, colour, rel_pos: [x ahead, "
                             "y left] (m), state}, with names instead of indices"))
    out += [
        FieldSpec(name="room_name", dtype="str",
                  description="the type of `room` (" + ", ".join(ROOM_TYPES) + "); empty "
                  "when `room` is -1"),
        FieldSpec(name="action_result", dtype="json",
                  description="{primitive, ok, reason, collided} of the last action (reason: "
                  "why it failed, 'collided' for a move stopped on contact, else empty)"),
    ]
    return tuple(out)


class Track1Episode(TrackEpisode):
    """One live Track 1 episode."""

    def __init__(self, scenario: Scenario[Track1Scenario], spec: Track1Scenario) -> None:
        from simhost.worlds.track1 import HouseEnv

        self.scenario = scenario
        self.spec = spec
        self.task = self.spec.task
        self.env = HouseEnv(split=self.spec.split)
        self.observation_spec = _observation_spec(self.env)
        self.action_spec = _action_spec(self.env.config)
        self.by_pixel = self.env.config.actions_by == "pixel"
        self.exception = ControlledException(
            self.spec.exception, self.task, scenario.seed,
            hidden=not self.spec.split.config.reveal_exceptions)
        self._obs: dict[str, np.ndarray] = {}
        self._info: HouseInfo | None = None
        self._ready = False
        self.steps = 0
        self.stage_steps: dict[str, int] = {}
        self.path: dict[str, float] = {}
        self.collisions = 0
        self.deadlocks = 0
        self.redundant = 0
        self._anchor: tuple[float, float, int] | None = None
        self.seen: set[int] = set()
        #: What the agent was shown, each item with its first step (the audit's ``Shown``,
        #: fed from every observation, message and action result the host served).
        self.shown = Shown()
        self.gt_exploration: Any = None
        self.gt_execution: Any = None
        self.answers: dict[str, Any] = {}
        self.plan: Track1Plan | None = None
        self.plan_error = ""
        self.exec_start: tuple[int, Point] | None = None
        self.marks: list[dict[str, int | None]] = [dict.fromkeys(g.subgoals) for g in
                                                   self.task.goals]
        self.success_step: int | None = None
        self.path_at_success: float | None = None

    @property
    def house(self) -> Any:
        """The simulated house (``simhost.worlds.track1.House``)."""
        assert self.env.house is not None
        return self.env.house

    # ---------------------------------------------------------------- TrackEpisode
    def reset(self) -> Observation:
        self._obs, self._info = self.env.reset_typed(seed=self.scenario.seed)
        digest = self.env.layout.digest()
        if digest != self.spec.layout_digest:
            raise RuntimeError(f"house {self.scenario.seed} was generated differently "
                               f"({digest[:12]} vs {self.spec.layout_digest[:12]})")
        self._ready = True
        self.seen.update(self.perceived_ids())
        return self.observe()

    def observe(self) -> Observation:
        tensors = {k: v.astype(np.uint8) if v.dtype == np.int8 else v
                   for k, v in self._obs.items()}
        info = self._info
        data: dict[str, Any] = {"detections": [], "room_name": "",
                                "action_result": {"collided": False}}
        if info is not None:
            r = info.action_result
            data = {
                "detections": [d.to_dict() for d in info.detections],
                "room_name": info.room_type or "",
                "action_result": {"ok": r.ok, "reason": r.reason, "primitive": r.primitive,
                                  "collided": bool(r.collided)},
            }
        if not self.env.config.detections:
            del data["detections"]
        if self._ready:
            self.shown.observe(self.steps, data, tensors)
        return Observation(tensors=tensors, data=data)

    def step_budget(self, stage: str) -> int | None:
        """The episode's step cap for a stage (``_budgets``); None for planning."""
        return self.spec.budgets.get(stage)

    def poses(self) -> Mapping[str, Pose]:
        """The robot's true pose (organizer-only; its odometry may drift)."""
        if not self._ready:
            return {}
        x, y, yaw = self.house.robot_pose
        return {"robot": Pose(position=(x, y, 0.0),
                              orientation=(math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)))}

    def on_stage_start(self, stage: str) -> tuple[HostMessage, ...]:
        messages = self._messages(stage)
        for m in messages:
            self.shown.message(self.steps, {"data": m.data})
        return messages

    def _messages(self, stage: str) -> tuple[HostMessage, ...]:
        if stage == EXPLORATION:
            return (HostMessage(type="notice", data={"text": (
                "Explore the house and build your world model; /output/world_model.json at "
                "the end of this stage is graded, and queries about it follow.")}),)
        if stage == PLANNING:
            t = self.task
            instruction: dict[str, Any] = {
                "text": t.text, "steps": list(t.steps),
                "plan_format": {"subgoals": "list of strings", "route": "room ids in "
                                "visiting order", "doors": "door ids in crossing order"}}
            if t.substitute_rule:
                instruction["substitutes"] = t.substitute_rule
            return (
                HostMessage(type="instruction", data=instruction),
                HostMessage(type="queries", data={
                    "queries": _queries.to_send(
                        self.spec.queries, self.seen if self.env.config.detections else ()),
                    "answer_with": "an answer request during planning: {query id: answer}; "
                    "'unknown' scores as wrong, never below zero"}),
            )
        return (HostMessage(type="notice", data={"text": "Execute your plan; send done when "
                                                 "the task is complete."}),)

    def on_stage_end(
        self, stage: str, *, ended_by: str, payload: Mapping[str, Any]
    ) -> tuple[Mapping[str, Any], ...]:
        if not self._ready:
            return ()
        if stage == EXPLORATION:
            self.gt_exploration = self.env.ground_truth()
            return ()
        if stage != PLANNING:
            return ()
        self.plan, self.plan_error = parse_plan(payload)
        events: list[Mapping[str, Any]] = [{
            "event": "plan", "plan": None if self.plan is None else self.plan.model_dump(),
            "error": self.plan_error}]
        x, y, _ = self.house.robot_pose
        self.exec_start = (self.steps, (x, y))
        self.gt_execution = self.env.ground_truth()
        events += self._reobserve(self.exception.start_execution(self))
        return tuple(events)

    def step(self, stage: str, action: Mapping[str, Any]) -> StepOutcome:
        from simhost.worlds.track1 import PRIMITIVES

        self.steps += 1
        self.stage_steps[stage] = self.stage_steps.get(stage, 0) + 1
        if "primitive" not in action:
            return self._refuse(f"no primitive: send one of {list(PRIMITIVES)}")
        primitive = PRIMITIVES[int(action["primitive"])]
        if stage == PLANNING and primitive != "noop":
            return self._refuse("nothing moves during planning: only noop is allowed")
        if primitive == "done" and stage != EXECUTION:
            return self._refuse("done ends the task during execution; end this stage with "
                                "an end_stage request")
        x0, y0, yaw0 = self.house.robot_pose
        move = action.get("move")
        sent: dict[str, Any] = {"primitive": PRIMITIVES.index(primitive),
                                "move": np.zeros(2, np.float32) if move is None else move}
        if self.by_pixel:
            sent.update({k: action[k] for k in ("target_px", "tool_px", "target", "tool")
                         if k in action})
        else:
            sent.update(target=int(action.get("target", 0)), tool=int(action.get("tool", 0)))
        self._obs, _, terminated, _, info = self.env.step_typed(sent)
        self._info = info
        acted = action
        if self.by_pixel:  # the rules that follow read what the pixels named
            target, tool = self.env.resolved
            acted = {**action, "target": -1 if target is None else target,
                     "tool": -1 if tool is None else tool}
        x1, y1, yaw1 = self.house.robot_pose
        result = info.action_result
        moved = math.hypot(x1 - x0, y1 - y0)
        self.path[stage] = self.path.get(stage, 0.0) + moved
        self.collisions += bool(info.collided)
        self._track_deadlock(x1, y1, primitive, result.ok)
        events: list[Mapping[str, Any]] = []
        if stage == EXPLORATION:
            self.seen.update(self.perceived_ids())
        elif stage == EXECUTION:
            turned = abs(math.remainder(yaw1 - yaw0, math.tau))
            if (primitive == "noop" or not result.ok
                    or (primitive == "move" and moved < 0.02 and turned < 0.02)):
                self.redundant += 1
            events += self._reobserve(self.exception.on_step(self, acted, result))
            events += self._progress()
        ok = bool(result.ok)
        self.shown.action(self.steps, action, {"ok": result.ok, "reason": result.reason,
                                               "primitive": result.primitive})
        out_action = ActionResult(applied=ok, ok=ok, reason=result.reason)
        if terminated and stage == EXECUTION:
            events.append({"event": "done", "step": self.steps, "success": self.success()})
            return StepOutcome(observation=self.observe(), action=out_action, episode_over=True,
                               end_reason=EndReason.COMPLETED, events=tuple(events))
        return StepOutcome(observation=self.observe(), action=out_action, events=tuple(events))

    def answer(self, stage: str, answers: Mapping[str, Any]) -> StepOutcome:
        if stage != PLANNING:
            return StepOutcome(observation=self.observe(), action=ActionResult(
                applied=False, ok=False, reason="answers are taken during planning only"))
        asked = {q.id for q in self.spec.queries}
        unknown = sorted(set(answers) - asked)
        for key in set(answers) & asked:
            self.answers[key] = answers[key]
        reason = f"unknown query ids ignored: {unknown[:10]}" if unknown else ""
        return StepOutcome(observation=self.observe(),
                           action=ActionResult(applied=True, ok=not unknown, reason=reason),
                           events=({"event": "answers", "count": len(answers)},))

    def sim_state(self) -> bytes:
        return self.env.get_state() if self._ready else b""

    def state_hash(self) -> str:
        return self.env.state_hash() if self._ready else ""

    def close(self) -> None:
        self.env.close()

    # ---------------------------------------------------------------- what the agent sees
    def perceived_ids(self) -> set[int]:
        """Ids in the agent's detections at this step; without a detector (``vision``),
        the instances its camera frame shows."""
        if not self.env.config.detections:
            return self.env.frame_instances() if self._ready else set()
        return set() if self._info is None else {int(d.id) for d in self._info.detections}

    def _reobserve(self, events: list[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
        """After an exception was applied, the step's observation shows it."""
        if any(e.get("event") == "exception" for e in events):
            self._obs, self._info = self.env.observe_typed()
        return events

    def _refuse(self, reason: str) -> StepOutcome:
        return StepOutcome(observation=self.observe(),
                           action=ActionResult(applied=False, ok=False, reason=reason))

    def _track_deadlock(self, x: float, y: float, primitive: str, ok: bool) -> None:
        """A deadlock: DEADLOCK_STEPS steps in a row within DEADLOCK_RADIUS, nothing done."""
        if (self._anchor is None or math.hypot(x - self._anchor[0], y - self._anchor[1])
                > DEADLOCK_RADIUS or (ok and primitive not in ("move", "noop"))):
            self._anchor = (x, y, self.steps)
        elif self.steps - self._anchor[2] >= DEADLOCK_STEPS:
            self.deadlocks += 1
            self._anchor = (x, y, self.steps)

    # ---------------------------------------------------------------- the task
    def accepted_destinations(self, goal: Goal) -> list[int]:
        """Where a goal may be completed now: the named receptacle or target, else (the
        named container became unusable) the other containers of its room."""
        world = self.house.world
        if goal.kind == "place" and goal.container and goal.receptacle in world.unavailable:
            return [r for r in goal.substitutes if r not in world.unavailable]
        return [goal.destination]

    def accepted_tools(self, goal: Goal) -> list[int]:
        """The named tool, else (it was taken away) the others with the same use."""
        world = self.house.world
        if goal.kind != "use":
            return []
        assert goal.tool is not None
        if goal.tool in world.removed:
            return [s for s in goal.substitutes if s not in world.removed]
        return [goal.tool]

    def house_task(self, goal: Goal) -> Any:
        """A goal as the environment's ``HouseTask``."""
        from simhost.worlds.track1 import HouseTask

        if goal.kind == "place":
            return HouseTask(kind="place", object=goal.object,
                             receptacles=tuple(self.accepted_destinations(goal)))
        return HouseTask(kind="use", target=goal.target, affordance=goal.affordance,
                         tools=tuple(self.accepted_tools(goal)))

    def goal_done(self, goal: Goal) -> bool:
        return bool(self.house.task_satisfied(self.house_task(goal)))

    def success(self) -> bool:
        """Whether every goal holds now."""
        return self._ready and all(self.goal_done(g) for g in self.task.goals)

    def recoverable(self) -> bool:
        """Whether every goal can still be completed from where the robot is: each on its own
        (the environment's check), and the place goals together (goals left to do whose
        accepted receptacles lie within a set need as many free slots in that set: two goals
        whose named container became unusable share its substitutes)."""
        if not all(self.env.has_recoverable_path(self.house_task(g)) for g in self.task.goals):
            return False
        world, layout = self.house.world, self.env.layout
        pending = [frozenset(self.accepted_destinations(g)) for g in self.task.goals
                   if g.kind == "place" and not self.goal_done(g)]
        for group in set(pending):
            free = sum(layout.entity(r).slots - len(world.contents(r)) for r in group
                       if r not in world.unavailable)
            if sum(1 for p in pending if p <= group) > free:
                return False
        return True

    def _progress(self) -> list[Mapping[str, Any]]:
        """Marks the key subgoals reached at this step."""
        house = self.house
        held = house.world.held
        events: list[Mapping[str, Any]] = []
        for k, (goal, marks) in enumerate(zip(self.task.goals, self.marks, strict=True)):
            picked = (held == goal.fetched if goal.kind == "place"
                      else held in self.accepted_tools(goal))
            dests = self.accepted_destinations(goal)
            reached = picked and any(house.in_reach(r) for r in dests)
            now = {
                "picked": picked,
                "reached": reached,
                "opened": reached and goal.container and any(
                    house.world.container_state(r) == "open" for r in dests),
            }
            for key in marks:
                if marks[key] is None and (now[key] if key in now else self.goal_done(goal)):
                    marks[key] = self.steps
                    events.append({"event": "subgoal", "goal": k, "subgoal": key,
                                   "step": self.steps})
        if self.success_step is None and self.success():
            self.success_step = self.steps
            self.path_at_success = self.path.get(EXECUTION, 0.0)
            events.append({"event": "task_satisfied", "step": self.steps})
        return events

    # ---------------------------------------------------------------- outcome
    def _reference(self) -> float | None:
        """The efficiency score's reference: the shortest route from where execution started
        through the true access poses of each goal (the substitute or new place the
        exception forced, the door it locked from where it locked)."""
        if self.exec_start is None or self.gt_execution is None:
            return None
        truth, (start_step, start) = self.gt_execution, self.exec_start
        goals = self.task.goals
        swap: dict[tuple[int, str], Point] = {}
        for k, g in enumerate(goals):
            obj = truth.object(g.fetched)
            if obj is not None and obj.held:
                swap[(k, "from")] = start
        rec = self.exception.record
        lock: tuple[int, Point, int] | None = None
        if rec is not None:
            g, k = goals[rec.goal], rec.goal
            if rec.type == "object_relocation":
                swap[(k, "via")] = rec.pose
                swap[(k, "from")] = _access_of(truth, int(rec.details["receptacle"]))
            elif rec.type == "tool_substitution":
                tools = self.accepted_tools(g)
                used = self.house.world.used_by.get(g.target)
                best = used if used in tools else min(
                    tools, key=lambda t: math.dist(_access_of(truth, t), start))
                swap[(k, "from")] = _access_of(truth, best)
            elif rec.type == "container_unavailable":
                place = self.house.world.places.get(g.fetched)
                dest = place[0] if place is not None else self.accepted_destinations(g)[0]
                swap[(k, "to")] = _access_of(truth, dest)
            else:
                lock = (rec.step, rec.pose, rec.subject)
        points = goal_points(truth, goals, start, swap)
        # When each waypoint was reached, to place the lock on the route.
        steps = [start_step]
        for k, marks in enumerate(self.marks):
            if (k, "via") in swap:
                steps.append(rec.step if rec is not None else start_step)
            steps += [marks.get("picked") or start_step,
                      marks.get("placed") or marks.get("used") or start_step]
        waypoints = [(p, frozenset[int]()) for p in points]
        if lock is not None:
            at = next((i for i, s in enumerate(steps) if s > lock[0]), len(points))
            waypoints.insert(at, (lock[1], frozenset()))
            waypoints = [(p, frozenset({lock[2]}) if i >= at else b)
                         for i, (p, b) in enumerate(waypoints)]
        return reference_length(self.env.layout, waypoints)

    def outcome(self) -> Track1Outcome:
        if not self._ready:
            return Track1Outcome(started=False, task=self.task,
                                 planned_exception=self.spec.exception)
        success = self.success()
        execution = ExecutionStats(
            start_step=None if self.exec_start is None else self.exec_start[0],
            start_pose=None if self.exec_start is None else self.exec_start[1],
            steps=self.stage_steps.get(EXECUTION, 0), redundant=self.redundant,
            path_at_success=self.path_at_success,
            reference_length=self._reference() if success else None)
        return Track1Outcome(
            started=True, task=self.task, planned_exception=self.spec.exception,
            exception=self.exception.record, exception_skipped=self.exception.skipped,
            success=success,
            goals=tuple(GoalProgress(subgoals=dict(m), done=self.goal_done(g))
                        for g, m in zip(self.task.goals, self.marks, strict=True)),
            plan=self.plan, plan_error=self.plan_error,
            queries=_queries.grade(self.spec.queries, self.answers, self.gt_exploration),
            gt_exploration=self.gt_exploration, gt_final=self.env.ground_truth(),
            steps=self.steps, stage_steps=self.stage_steps, path=self.path,
            execution=execution, collisions=self.collisions, deadlocks=self.deadlocks,
            sim_warnings=0 if self._info is None else int(sum(self._info.sim_warnings.values())),
            shown=shown_record(self.shown))


def shown_record(shown: Shown) -> ShownRecord:
    """What the agent was shown: ids, room ids and states with their first step."""
    return ShownRecord(ids=dict(sorted(shown.ids.items())),
                       rooms=dict(sorted(shown.rooms.items())),
                       states={k: dict(v) for k, v in sorted(shown.states.items())})


def shown_from(record: ShownRecord | None) -> Shown | None:
    """The ``Shown`` an outcome recorded (None: an outcome without the record)."""
    if record is None:
        return None
    return Shown(ids=dict(record.ids), rooms=dict(record.rooms),
                 states={k: dict(v) for k, v in record.states.items()})


def _access_of(truth: Any, entity: int) -> Point:
    rec = truth.receptacle(entity)
    if rec is None:
        obj = truth.object(entity)
        rec = truth.receptacle(obj.receptacle) if obj is not None else None
    assert rec is not None, f"no place for entity {entity}"
    return (rec.access[0], rec.access[1])


def parse_plan(payload: Mapping[str, Any]) -> tuple[Track1Plan | None, str]:
    """The submitted plan (``payload["plan"]``, or the payload itself) and an error text."""
    from pydantic import ValidationError

    raw = payload.get("plan", payload) if isinstance(payload, Mapping) else None
    if not raw:
        return None, "no plan submitted"
    try:
        return Track1Plan.model_validate(raw), ""
    except ValidationError as e:
        return None, f"invalid plan: {e.errors()[0]['msg']}"
