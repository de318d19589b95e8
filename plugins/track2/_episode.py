"""``Track2Episode``: one hidden bench instance, three stages, up to three attempts.

Stages (paper Table V): ``demonstration`` (the host says where the packet is), ``parsing``
(nothing moves: a step is refused with a reason and counts as an invalid action), then
``execution``. Execution runs attempts on the hidden instance:

- an attempt ends on success, when the agent sends ``end_attempt: 1`` (the request's
  ``motion``, if any, is not applied), or after ``attempt_steps`` steps;
- the reply to the step that ended a failed attempt carries a ``HostMessage(type=
  "attempt_result")`` and the first observation of the next attempt: the instance is reset
  with the next attempt's seed (on the official splits its parts and fixtures sit a few
  millimetres elsewhere, and the observation noise is new: a retry is not a replay);
- the episode ends at the first success (``end_reason="success"``) or when the last attempt
  ends (``"attempts_used"``). Attempts share the execution stage's budget (wall clock, and
  a step budget of ``max_attempts * (attempt_steps + 1)``); if it runs out, the attempt
  under way is the last.

The observation's JSON part tells the agent ``attempt`` (1-based), ``attempts_left`` (after
this one) and ``attempt_steps_left``; its tensors are the bench's (see ``OBS_TEXT``).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from plugins.track2._outcome import AttemptRecord, Track2Outcome
from plugins.track2._scenario import Track2Scenario
from schemas import ActionResult, EndReason, FieldSpec, HostMessage
from simhost.host import Observation, Pose, StageEnd, StepOutcome, TrackEpisode
from simhost.worlds.track2 import BenchInfo

DEMONSTRATION, PARSING, EXECUTION = "demonstration", "parsing", "execution"
DEMO_FOLDER = "demo"
CONTAINER_DEMO = "/input/demo"
EXCESS_FORCE = 25.0  # N: above a firm grasp (each finger squeezes with at most 20 N)
JERK = 1.2  # a change of a motion command by more than this in one step is jerky
OBS_TEXT = {
    "proprio": "exact: TCP x, y, z (m, world frame, table top z = 0), yaw (rad), finger "
               "opening (m), left and right finger contact (0 or 1)",
    "parts": "one row per task part (family order, see the track README), padding rows all "
             "zero: present (1 or 0), x, y, z (m), qw, qx, qy, qz (world frame), joint (hinge "
             "angle in rad or slide position in m on the dev split; 0 on the official "
             "splits: not observed), age (s: how old the state shown is). Official splits: "
             "measured with noise, at a lower rate, with latency, kept stale while the "
             "gripper hides the part from all three cameras, yaw only modulo the part's "
             "symmetry",
    "force": "exact: normal contact force on the left finger, right finger and palm (N), then "
             "the net contact force on the gripper, world frame x, y, z (N)",
    "goal": "dev split only: [stated (1 or 0), g1, g2, g3], the task's goal parameters "
            "(family README); zeros when the task states none",
    "rgb": "overview camera (the robot's side, the near half of the bench; pose and field "
           "of view in the track README), H x W x 3, 8-bit RGB; refreshed when parts are "
           "measured",
    "depth": "overview camera, H x W, depth along the optical axis (m)",
    "segmentation": "overview camera, H x W: 0 nothing, k the part of parts row k - 1, "
                    "-1 the gripper",
    "rgb_front": "front camera (across the table, facing the robot: the far half of the "
                 "bench), H x W x 3, 8-bit RGB; refreshed with rgb",
    "depth_front": "front camera, H x W, depth along the optical axis (m)",
    "segmentation_front": "front camera, H x W: 0 nothing, k the part of parts row k - 1, "
                          "-1 the gripper",
    "rgb_top": "top camera (straight down from 2.36 m at the press wells' region, image "
               "up +x, right -y, about x 0.04-0.22 m and y -0.12-0.12 m at the buttons' "
               "height: the buttons at the bottom of the wells; pose and field of view in "
               "the track README), H x W x 3, 8-bit RGB; refreshed with rgb",
    "depth_top": "top camera, H x W, depth along the optical axis (m)",
    "segmentation_top": "top camera, H x W: 0 nothing, k the part of parts row k - 1, "
                        "-1 the gripper",
}


@dataclass
class _Stability:
    """What the stability component counts over the execution's steps."""

    steps: int = 0
    excess_force_steps: int = 0
    drops: int = 0
    limit_steps: int = 0
    jerk_steps: int = 0
    env_invalid: int = 0
    sim_warnings: int = 0
    refused: int = 0


class Track2Episode(TrackEpisode):
    """The live episode around a ``BenchEnv`` of the hidden instance."""

    def __init__(self, hidden: Track2Scenario) -> None:
        from simhost.worlds.track2 import BenchEnv

        self.hidden = hidden
        self.params = self.hidden.instance
        self.cap = self.hidden.attempt_steps
        self.max_attempts = self.hidden.max_attempts
        self.env = BenchEnv(self.params, config=self.hidden.bench, max_steps=self.cap)
        spaces = self.env.observation_space.spaces  # type: ignore[union-attr]
        tensors = []
        for key, space in spaces.items():
            dtype = str(space.dtype)
            tensors.append(FieldSpec(
                name=key, dtype=dtype, shape=tuple(space.shape), tensor=True,  # type: ignore
                low=float(np.min(space.low)), high=float(np.max(space.high)),  # type: ignore
                description=OBS_TEXT[key]))
        self.observation_spec = (*tensors,
            FieldSpec(name="attempt", dtype="int32", low=0, high=self.max_attempts,
                      description="the attempt under way (1-based; 0 before execution)"),
            FieldSpec(name="attempts_left", dtype="int32", low=0, high=self.max_attempts,
                      description="attempts left after this one"),
            FieldSpec(name="attempt_steps_left", dtype="int32", low=0, high=self.cap,
                      description="steps left in this attempt"),
        )
        self.action_spec = (
            FieldSpec(name="motion", dtype="float32", shape=(5,), low=-1.0, high=1.0,
                      description="[dx, dy, dz, dyaw, grip]: move the hand's control target by "
                      "up to 0.015 m per axis and 0.15 rad per step (world frame; kept within "
                      "0.02 m and 0.3 rad of the hand); grip -1 closed .. +1 open (0.09 m)"),
            FieldSpec(name="end_attempt", dtype="int32", shape=(), low=0, high=1,
                      description="1 ends the current attempt (its motion is not applied); "
                      "the instance is reset for the next one"),
        )
        self._obs: dict[str, np.ndarray] = {}
        self._attempts: list[AttemptRecord] = []
        self._current: AttemptRecord | None = None
        self._attempt_t0 = 0.0
        self._stage_t0: dict[str, float] = {}
        self._durations: dict[str, float] = {}
        self._prev_motion: np.ndarray | None = None
        self._stats = _Stability()
        self._max_force = 0.0
        self._progress = 0.0

    # ---------------------------------------------------------------- TrackEpisode
    def reset(self) -> Observation:
        self._reset_env(1)
        return self.observe()

    def observe(self) -> Observation:
        a = self._current or (self._attempts[-1] if self._attempts else None)
        data = {
            "attempt": a.index if a else 0,
            "attempts_left": self.max_attempts - (a.index if a else 0),
            "attempt_steps_left": (self.cap - self._current.steps if self._current
                                   else 0 if self._attempts else self.cap),
        }
        return Observation(tensors=self._obs, data=data)

    def step_budget(self, stage: str) -> int | None:
        """Execution: every attempt's steps plus one request to end it."""
        return self.max_attempts * (self.cap + 1) if stage == EXECUTION else None

    def poses(self) -> Mapping[str, Pose]:
        """The TCP and every present part, true poses (organizer-only)."""
        from simhost.worlds.track2 import quat_z

        ee = self.env.sim.ee()
        out = {"tcp": Pose(position=(float(ee[0]), float(ee[1]), float(ee[2])),
                           orientation=tuple(float(x) for x in quat_z(float(ee[3]))))}
        for name, row in zip(self.env.task.part_names, self.env.task.parts(), strict=True):
            if row[0] > 0.5:
                out[name] = Pose(position=(float(row[1]), float(row[2]), float(row[3])),
                                 orientation=(float(row[4]), float(row[5]), float(row[6]),
                                              float(row[7])))
        return out  # type: ignore[return-value]

    def on_stage_start(self, stage: str) -> tuple[HostMessage, ...]:
        self._stage_t0[stage] = time.monotonic()
        if stage == DEMONSTRATION:
            return (
                HostMessage(type="demonstration", data={
                    "path": CONTAINER_DEMO, "folder": DEMO_FOLDER, "format": "eagc-demo/v2",
                    "hint": "the packet is $EAGC_INPUT/demo: use os.environ['EAGC_INPUT'] "
                            "(it is /input in a container)",
                }),
                HostMessage(type="instruction", data={
                    "text": "receive the demonstration; nothing moves in this stage; "
                            "end_stage when ready"}),
            )
        if stage == PARSING:
            return (HostMessage(type="instruction", data={
                "text": "parse the demonstration and adapt; nothing moves in this stage; write "
                        "/output/task_model.json and end_stage to start execution"}),)
        if stage == EXECUTION:
            self._start_attempt()
            return (HostMessage(type="instruction", data={
                "text": f"do on this instance what the demonstration did: up to "
                        f"{self.max_attempts} attempts of at most {self.cap} steps; send "
                        "end_attempt=1 to give up an attempt (the instance is reset)",
                "max_attempts": self.max_attempts, "attempt_steps": self.cap}),)
        return ()

    def on_stage_end(
        self, stage: str, *, ended_by: StageEnd, payload: Mapping[str, Any]
    ) -> tuple[Mapping[str, Any], ...]:
        self._durations[stage] = time.monotonic() - self._stage_t0.get(stage, time.monotonic())
        if stage == EXECUTION and self._current is not None:
            att = self._close_attempt(f"stage_{ended_by}")
            return ({"event": "attempt_end", **att.model_dump()},)
        return ()

    def step(self, stage: str, action: Mapping[str, Any]) -> StepOutcome:
        if stage != EXECUTION or self._current is None:
            self._stats.refused += 1
            return self._refuse(f"nothing moves during {stage!r}: end the stage (end_stage) "
                                "to reach execution")
        if int(action.get("end_attempt", 0) or 0) == 1:
            return self._end_attempt("agent", applied=False)
        motion = action.get("motion")
        if motion is None:
            self._stats.refused += 1
            return self._refuse("give motion [dx, dy, dz, dyaw, grip] or end_attempt=1")
        att = self._current
        t0 = time.perf_counter()
        self._obs, _, _, _, info = self.env.step_typed(motion)
        att.sim_s += time.perf_counter() - t0
        att.steps += 1
        self._account(np.asarray(motion, dtype=float), info)
        att.peak_progress = max(att.peak_progress, float(info.progress))
        att.final_progress = float(info.progress)
        att.final_value = None if info.value is None else float(info.value)
        if info.success:
            att.success = True
            att = self._close_attempt("success")
            return StepOutcome(
                observation=self.observe(),
                action=ActionResult(applied=True, ok=True),
                messages=(self._result_message(att),),
                episode_over=True,
                end_reason=EndReason.SUCCESS,
                events=({"event": "attempt_end", **att.model_dump()},),
            )
        if att.steps >= self.cap:
            return self._end_attempt("step_cap", applied=True)
        return StepOutcome(observation=self.observe(), action=ActionResult(applied=True, ok=True))

    def sim_state(self) -> bytes:
        return self.env.get_state()

    def state_hash(self) -> str:
        return self.env.state_hash()

    def outcome(self) -> Track2Outcome:
        attempts = [a.model_copy() for a in self._attempts]  # the live records go on changing
        if self._current is not None:  # still under way (the host never ended the stage)
            attempts.append(self._current.model_copy(update={"ended_by": "unfinished"}))
        win = next((a.index for a in attempts if a.success), None)
        exec_s = self._durations.get(EXECUTION, 0.0)
        sim_s = sum(a.sim_s for a in attempts)
        adapt = (self._durations.get(DEMONSTRATION, 0.0) + self._durations.get(PARSING, 0.0)
                 + max(0.0, exec_s - sim_s))
        return Track2Outcome(
            family=self.params.family,
            distance=self.hidden.distance,
            attempts=attempts,
            max_attempts=self.max_attempts,
            attempt_steps=self.cap,
            success=win is not None,
            success_attempt=win,
            # Rounded: a score must not change with microseconds of timing noise.
            stage_durations_s={k: round(v, 2) for k, v in self._durations.items()},
            adapt_time_s=round(adapt, 2),
            max_contact_force=self._max_force,
            **asdict(self._stats),
        )

    def close(self) -> None:
        self.env.close()

    # ---------------------------------------------------------------- internals
    def _reset_env(self, attempt: int) -> None:
        self._obs, info = self.env.reset_typed(seed=self.hidden.reset_seed(attempt),
                                               options={"bias_seed": self.hidden.episode_seed})
        self._progress = float(info.progress)

    def _refuse(self, reason: str) -> StepOutcome:
        return StepOutcome(observation=self.observe(),
                           action=ActionResult(applied=False, ok=False, reason=reason))

    def _account(self, motion: np.ndarray, info: BenchInfo) -> None:
        s = self._stats
        s.steps += 1
        force = float(info.contact_force)
        self._max_force = max(self._max_force, force)
        s.excess_force_steps += force > EXCESS_FORCE
        s.drops += info.drops
        s.limit_steps += bool(info.joint_limit)
        s.env_invalid += bool(info.invalid_action)
        s.sim_warnings += len(info.sim_warnings)
        prev = self._prev_motion
        if prev is not None and float(np.max(np.abs(motion[:4] - prev[:4]))) > JERK:
            s.jerk_steps += 1
        self._prev_motion = motion

    def _start_attempt(self) -> None:
        self._current = AttemptRecord(index=len(self._attempts) + 1,
                                      start_progress=self._progress,
                                      peak_progress=self._progress,
                                      final_progress=self._progress)
        self._attempt_t0 = time.monotonic()
        self._prev_motion = None

    def _close_attempt(self, ended_by: str) -> AttemptRecord:
        att = self._current
        assert att is not None
        att.ended_by = ended_by
        att.wall_s = time.monotonic() - self._attempt_t0
        self._attempts.append(att)
        self._current = None
        return att

    def _result_message(self, att: AttemptRecord) -> HostMessage:
        return HostMessage(type="attempt_result", data={
            "attempt": att.index, "success": att.success, "ended_by": att.ended_by,
            "steps": att.steps, "attempts_left": self.max_attempts - att.index,
        })

    def _end_attempt(self, why: str, *, applied: bool) -> StepOutcome:
        att = self._close_attempt(why)
        events = ({"event": "attempt_end", **att.model_dump()},)
        message = self._result_message(att)
        result = ActionResult(applied=applied, ok=True, reason=f"attempt {att.index} ended ({why})")
        if att.index >= self.max_attempts:
            return StepOutcome(observation=self.observe(), action=result, messages=(message,),
                               episode_over=True, end_reason=EndReason.ATTEMPTS_USED, events=events)
        self._reset_env(att.index + 1)
        self._start_attempt()
        return StepOutcome(observation=self.observe(), action=result, messages=(message,),
                           events=events)
