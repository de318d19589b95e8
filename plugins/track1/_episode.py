"""``Track1Episode``: one live Track 1 episode around a ``HouseEnv`` (the rules of the game).

Stages: ``exploration`` → ``planning`` (nothing moves: any primitive but ``noop`` is refused
and counts as an invalid action; the plan comes in the ``end_stage`` payload) →
``execution`` (``done`` ends the episode). At the start of planning the agent gets the
instruction and the queries; it answers them with ``answer`` requests during planning.

The controlled exception (at most one, planned by the scenario) is applied where it matters:

- ``object_relocation`` and ``tool_substitution``: when execution starts (the model built in
  exploration is then out of date);
- ``door_lock``: when the robot comes within ``TRIGGER_DIST`` of a door on the agent's
  submitted route (``doors``, else ``route``, else the shortest path to the task's rooms);
- ``container_unavailable``: when the robot, holding the object, comes within
  ``TRIGGER_DIST`` of the named container.

Before it is applied for good, the environment must still have a recoverable path
(``HouseEnv.has_recoverable_path``); otherwise the world is rolled back and the exception is
skipped. Its first observable effect (the agent could see it, or an action hit it) starts the
detection window of the recovery score.

Observation: every ``HouseEnv`` array as a tensor (int8 flags as uint8); JSON data:
``detections`` (a JSON list: ``[{id, kind, category, colour, rel_pos, state}]``, visible things
only), ``room_name`` (the current room's type) and ``action_result`` (a JSON object:
``{primitive, ok, reason, collided}``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from plugins._base import Scenario
from plugins.track1 import _queries
from plugins.track1._paths import reference_length
from plugins.track1._scenario import SUBSTITUTE_RULE, house_params
from schemas._protocol import ActionResult, FieldSpec, HostMessage
from simhost._episode import Observation, StageEnd, StepOutcome, TrackEpisode

EXPLORATION, PLANNING, EXECUTION = "exploration", "planning", "execution"
TRIGGER_DIST = 3.0
DEADLOCK_STEPS = 30
DEADLOCK_RADIUS = 0.3
EFFECT_RADIUS = 2.5

_OBS_TEXT = {
    "odometry": "x, y (m), yaw (rad) in the house frame",
    "range_scan": "planar range scan (m), counter-clockwise from straight ahead",
    "room": "current room id",
    "room_type": "index of the current room's type (see room_name)",
    "held": "id of the held item, -1 when the hand is empty",
    "last_action_ok": "1 when the last primitive succeeded",
    "collided": "1 when the last move stopped on contact",
    "det_mask": "1 for rows holding a detection (nearest first)",
    "det_id": "instance id of each detection, -1 when masked",
    "det_kind": "index into door, furniture, container, object, tool",
    "det_category": "category index (names in the detections data)",
    "det_colour": "colour index (names in the detections data)",
    "det_state": "visible state index (names in the detections data)",
    "det_rel_pos": "position in the robot frame (x ahead, y left), m",
    "rgb": "eye camera RGB",
    "depth": "eye camera depth (m)",
    "segmentation": "eye camera instance ids, -1 elsewhere",
}


def _action_spec() -> tuple[FieldSpec, ...]:
    from simhost.track1 import MAX_IDS, PRIMITIVES

    return (
        FieldSpec(name="primitive", dtype="int32", choices=PRIMITIVES,
                  description="the primitive, by index or name"),
        FieldSpec(name="move", dtype="float32", shape=(2,), low=-1.0, high=1.0,
                  description="move: [forward, turn]: turn by turn × 45° (counter-clockwise), "
                  "then drive forward × 0.5 m"),
        FieldSpec(name="target", dtype="int32", low=0, high=MAX_IDS - 1,
                  description="open/close/pick/use: the instance acted on; place: the "
                  "receptacle"),
        FieldSpec(name="tool", dtype="int32", low=0, high=MAX_IDS - 1,
                  description="use: the held tool"),
    )


def _observation_spec(env: Any) -> tuple[FieldSpec, ...]:
    from simhost.track1 import ROOM_TYPES

    out = []
    for name, box in env.observation_space.spaces.items():
        dtype = "uint8" if box.dtype == np.int8 else box.dtype.name
        out.append(FieldSpec(name=name, dtype=dtype, shape=tuple(box.shape),
                             low=float(np.min(box.low)), high=float(np.max(box.high)),
                             tensor=True, description=_OBS_TEXT.get(name, "")))
    out += [
        FieldSpec(name="detections", dtype="json", description="list of the visible "
                  "things: {id, kind, category, colour, rel_pos: [x ahead, y left], state}"),
        FieldSpec(name="room_name", dtype="str", choices=ROOM_TYPES,
                  description="the current room's type"),
        FieldSpec(name="action_result", dtype="json",
                  description="{primitive, ok, reason, collided} of the last action"),
    ]
    return tuple(out)


class Track1Episode(TrackEpisode):
    """One live Track 1 episode."""

    def __init__(self, scenario: Scenario) -> None:
        from simhost.track1 import HouseEnv

        self.scenario = scenario
        p = scenario.params
        self.task: dict[str, Any] = dict(p["task"])
        self.env = HouseEnv(params=house_params(p["house"]), render_rgbd=p["render_rgbd"],
                            image_size=tuple(p["image_size"]))
        self.observation_spec = _observation_spec(self.env)
        self.action_spec = _action_spec()
        self._obs: dict[str, np.ndarray] = {}
        self._info: dict[str, Any] = {}
        self._ready = False
        self.steps = 0
        self.stage_steps: dict[str, int] = {}
        self.path: dict[str, float] = {}
        self.collisions = 0
        self.deadlocks = 0
        self.redundant = 0
        self._anchor: tuple[float, float, int] | None = None
        self.seen: set[int] = set()
        self.visited: set[int] = set()
        self.gt_exploration: dict[str, Any] | None = None
        self.answers: dict[str, Any] = {}
        self.queries_sent: list[dict[str, Any]] = []
        self.plan: dict[str, Any] | None = None
        self.plan_error = ""
        self.exec_start: dict[str, Any] | None = None
        self.subgoals: dict[str, int | None] = {k: None for k in self.task["subgoals"]}
        self.marks: dict[str, tuple[float, float]] = {}
        self.used_with: int | None = None
        self.success_step: int | None = None
        self.planned: str | None = p["exception"]
        self.exc_type: str | None = p["exception"]
        self.exc_subject: int | None = None
        self.exception: dict[str, Any] | None = None
        self.skipped: str | None = None

    # ---------------------------------------------------------------- TrackEpisode
    def reset(self) -> Observation:
        self._obs, self._info = self.env.reset(seed=self.scenario.seed)
        digest = self.env.layout.digest()
        if digest != self.scenario.params["layout_digest"]:
            raise RuntimeError(f"house {self.scenario.seed} was generated differently "
                               f"({digest[:12]} vs {self.scenario.params['layout_digest'][:12]})")
        self._ready = True
        self.visited.add(self._room())
        self.seen.update(d["id"] for d in self._info["detections"])
        return self.observe()

    def observe(self) -> Observation:
        tensors = {k: v.astype(np.uint8) if v.dtype == np.int8 else v
                   for k, v in self._obs.items()}
        info = self._info
        result = info.get("action_result", {})
        data = {
            "detections": list(info.get("detections", [])),
            "room_name": info.get("room", {}).get("type", "hallway"),
            "action_result": {**result, "collided": bool(info.get("collided"))},
        }
        return Observation(tensors=tensors, data=data)

    def on_stage_start(self, stage: str) -> tuple[HostMessage, ...]:
        if stage == EXPLORATION:
            return (HostMessage(type="notice", data={"text": (
                "Explore the house and build your world model; /output/world_model.json at "
                "the end of this stage is graded, and queries about it follow.")}),)
        if stage == PLANNING:
            t = self.task
            self.queries_sent = _queries.to_send(self.scenario.params["queries"], self)
            return (
                HostMessage(type="instruction", data={
                    "text": t["text"], "steps": list(t["steps"]), "substitutes": SUBSTITUTE_RULE,
                    "plan_format": {"subgoals": "list of strings", "route": "room ids in "
                                    "visiting order", "doors": "door ids in crossing order"}}),
                HostMessage(type="queries", data={
                    "queries": self.queries_sent,
                    "answer_with": "an answer request during planning: {query id: answer}"}),
            )
        return (HostMessage(type="notice", data={"text": "Execute your plan; send done when "
                                                 "the task is complete."}),)

    def on_stage_end(
        self, stage: str, *, ended_by: StageEnd, payload: Mapping[str, Any]
    ) -> tuple[Mapping[str, Any], ...]:
        if not self._ready:
            return ()
        if stage == EXPLORATION:
            self.gt_exploration = self.env.ground_truth()
            return ()
        if stage != PLANNING:
            return ()
        from plugins.track1 import _exceptions

        events: list[Mapping[str, Any]] = []
        self.plan, self.plan_error = _exceptions.parse_plan(payload)
        events.append({"event": "plan", "plan": self.plan, "error": self.plan_error})
        x, y, _ = self.env.house.robot_pose  # type: ignore[union-attr]
        self.exec_start = {"pose": [x, y], "step": self.steps}
        self.marks["start"] = (x, y)
        events += _exceptions.on_execution_start(self)
        return tuple(events)

    def step(self, stage: str, action: Mapping[str, Any]) -> StepOutcome:
        from simhost.track1 import PRIMITIVES

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
        house = self.env.house
        assert house is not None
        x0, y0, yaw0 = house.robot_pose
        move = action.get("move")
        self._obs, _, terminated, _, self._info = self.env.step({
            "primitive": PRIMITIVES.index(primitive),
            "move": np.zeros(2, np.float32) if move is None else move,
            "target": int(action.get("target", 0)), "tool": int(action.get("tool", 0))})
        x1, y1, yaw1 = house.robot_pose
        result = self._info["action_result"]
        moved = math.hypot(x1 - x0, y1 - y0)
        self.path[stage] = self.path.get(stage, 0.0) + moved
        self.collisions += bool(self._info["collided"])
        self._track_deadlock(x1, y1, primitive, result["ok"])
        events: list[Mapping[str, Any]] = []
        if stage == EXPLORATION:
            self.seen.update(d["id"] for d in self._info["detections"])
            self.visited.add(self._room())
        elif stage == EXECUTION:
            turned = abs(math.remainder(yaw1 - yaw0, math.tau))
            if (primitive == "noop" or not result["ok"]
                    or (primitive == "move" and moved < 0.02 and turned < 0.02)):
                self.redundant += 1
            events += self._execution_step(primitive, action, result)
        ok = bool(result["ok"])
        out_action = ActionResult(applied=ok, ok=ok, reason=result["reason"])
        if terminated and stage == EXECUTION:
            events.append({"event": "done", "step": self.steps, "success": self.success()})
            return StepOutcome(observation=self.observe(), action=out_action, episode_over=True,
                               end_reason="completed", events=tuple(events))
        return StepOutcome(observation=self.observe(), action=out_action, events=tuple(events))

    def answer(self, stage: str, answers: Mapping[str, Any]) -> StepOutcome:
        if stage != PLANNING:
            return StepOutcome(observation=self.observe(), action=ActionResult(
                applied=False, ok=False, reason="answers are taken during planning only"))
        sent = {q["id"] for q in self.queries_sent}
        unknown = sorted(set(answers) - sent)
        for key in set(answers) & sent:
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

    # ---------------------------------------------------------------- bookkeeping
    def _room(self) -> int:
        return int(self._info["room"]["id"])

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

    def _execution_step(
        self, primitive: str, action: Mapping[str, Any], result: Mapping[str, Any]
    ) -> list[Mapping[str, Any]]:
        from plugins.track1 import _exceptions

        events = list(_exceptions.on_step(self, primitive, action, result))
        house = self.env.house
        assert house is not None
        t = self.task
        if (primitive == "use" and result["ok"] and t["kind"] == "use"
                and int(action.get("target", -1)) == t["target"]):
            self.used_with = int(action.get("tool", -1))
        held = house.world.held
        x, y, _ = house.robot_pose
        item = t["object"] if t["kind"] == "place" else None
        picked = (held == item) if item is not None else held in self.valid_tools()
        reached = picked and any(house.in_reach(r) for r in self.valid_targets())
        state = {
            "picked": lambda: picked,
            "reached": lambda: reached,
            "opened": lambda: reached and any(house.world.container_state(r) == "open"
                                              for r in self.valid_targets()),
            "placed": self.success,
            "used": self.success,
        }
        for key in self.subgoals:
            if self.subgoals[key] is None and state[key]():
                self.subgoals[key] = self.steps
                events.append({"event": "subgoal", "subgoal": key, "step": self.steps})
                if key == "picked":
                    self.marks["pick"] = (x, y)
        if self.success_step is None and self.success():
            self.success_step = self.steps
            self.marks["success"] = (x, y)
            self.exec_start = {**(self.exec_start or {}), "path_at_success":
                               self.path.get(EXECUTION, 0.0)}
            events.append({"event": "task_satisfied", "step": self.steps})
        return events

    # ---------------------------------------------------------------- the task
    def valid_targets(self) -> list[int]:
        """Where the task may be completed now: the named receptacle or target, else the
        substitutes of an unusable named container."""
        t, world = self.task, self.env.house.world  # type: ignore[union-attr]
        if t["kind"] == "use":
            return [t["target"]]
        if t["container"] and t["receptacle"] in world.unavailable:
            return [r for r in t["substitutes"] if r not in world.unavailable]
        return [t["receptacle"]]

    def valid_tools(self) -> list[int]:
        """The named tool, else (when it was taken away) its substitutes."""
        t, world = self.task, self.env.house.world  # type: ignore[union-attr]
        if t["kind"] != "use":
            return []
        if t["tool"] in world.removed:
            return [s for s in t["substitutes"] if s not in world.removed]
        return [t["tool"]]

    def success(self) -> bool:
        """Whether the main objective holds now."""
        if not self._ready:
            return False
        from simhost.track1 import AFFORDANCE_EFFECTS

        t, world = self.task, self.env.house.world  # type: ignore[union-attr]
        if t["kind"] == "place":
            place = world.places.get(t["object"])
            return place is not None and place[0] in self.valid_targets()
        after = AFFORDANCE_EFFECTS[t["affordance"]][1]
        return world.conditions.get(t["target"]) == after and self.used_with in self.valid_tools()

    def house_task(self) -> dict[str, Any]:
        """The task as a ``HouseTask`` dict (for ``has_recoverable_path``)."""
        t = self.task
        if t["kind"] == "place":
            return {"kind": "place", "object": t["object"], "receptacles": self.valid_targets()}
        return {"kind": "use", "target": t["target"], "affordance": t["affordance"]}

    # ---------------------------------------------------------------- outcome
    def outcome(self) -> dict[str, Any]:
        if not self._ready:
            return {"started": False, "task": self.task, "planned_exception": self.planned}
        gt = self.env.ground_truth()
        success = self.success()
        reference = None
        if success and "start" in self.marks:
            waypoints = []
            exc = self.exception
            lock = (frozenset({exc["details"]["door"]}) if exc and exc["type"] == "door_lock"
                    else frozenset())
            marks = [("start", self.exec_start["step"] if self.exec_start else 0),
                     ("pick", self.subgoals.get("picked") or 0), ("success", self.success_step)]
            if exc is not None and exc["type"] == "door_lock":
                self.marks["lock"] = tuple(exc["pose"])  # type: ignore[assignment]
                marks.append(("lock", exc["step"]))
            for name, step in sorted((m for m in marks if m[0] in self.marks),
                                     key=lambda m: m[1] or 0):
                blocked = lock if exc is not None and (step or 0) >= exc["step"] else frozenset()
                waypoints.append((self.marks[name], blocked))
            reference = reference_length(self.env.layout, waypoints)
        return {
            "started": True,
            "task": self.task,
            "planned_exception": self.planned,
            "exception": self.exception,
            "exception_skipped": self.skipped,
            "success": success,
            "subgoals": self.subgoals,
            "used_with": self.used_with,
            "plan": self.plan,
            "plan_error": self.plan_error,
            "queries": _queries.grade(self.scenario.params["queries"], self),
            "gt_exploration": self.gt_exploration,
            "gt_final": gt,
            "steps": self.steps,
            "stage_steps": self.stage_steps,
            "path": self.path,
            "execution": {
                "start": self.exec_start,
                "steps": self.stage_steps.get(EXECUTION, 0),
                "redundant": self.redundant,
                "reference_length": reference,
                "path_at_success": (self.exec_start or {}).get("path_at_success"),
            },
            "collisions": self.collisions,
            "deadlocks": self.deadlocks,
            "sim_warnings": int(sum(self._info.get("sim_warnings", {}).values())),
        }
