"""The sanity track: the whole pipeline in seconds, with the real tracks' shape.

A point robot in a 4 m arena. Stage ``explore``: find the target and write its position to
``world_model.json`` (object id ``"target"``). Stage ``reach``: drive onto it. When the robot
comes within 0.5 m, the controlled exception may move the target (``target_moved``); the
agent should notice, log an ``exception_detected`` record, update its model and reach the
new place. The score has the five components of Track 1's equation (1).

Scenario parameters (a campaign's split ``params``): ``exception_probability``, and
``render_rgbd`` / ``image_size`` ([width, height]) to add the overhead camera's ``rgb``,
``depth`` and ``segmentation`` to the observation, as Track 1 does when it renders.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, SerializerFunctionWrapHandler, model_serializer

from plugins._base import HiddenScenario, Scenario, ScoringInput, TrackPlugin
from plugins._files import EPISODE_LOG, FileRule
from plugins.sanity._picture import path_png
from schemas import (
    ActionResult,
    EndReason,
    FieldSpec,
    HostMessage,
    ScoreCard,
    WorldModel,
    ignored_note,
)
from simhost.host import (
    EpisodeOutcome,
    Observation,
    Pose,
    StageEnd,
    StageSpec,
    StepOutcome,
    TrackEpisode,
)

TRIGGER_RADIUS = 0.5
DETECT_WINDOW = 20  # steps after the exception's first observable effect
MODEL_TOLERANCE = 0.5  # metres: model error at which the model score reaches 0


class SanitySplitParams(BaseModel):
    """A sanity split's scenario parameters (a campaign split's ``params``; other keys are
    ignored)."""

    model_config = ConfigDict(frozen=True, extra="ignore")

    exception_probability: float = 0.5
    """The chance that the target moves when the robot comes near it."""
    render_rgbd: bool = False
    """Add the overhead camera's ``rgb``, ``depth`` and ``segmentation``."""
    image_size: tuple[int, int] = (64, 64)
    """Width, height of the camera's images."""


class SanityScenario(HiddenScenario):
    """One hidden sanity scenario (``Scenario.params`` as JSON; the camera's fields only
    when it renders)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    start: list[float]
    """The robot's start x, y (m)."""
    target: list[float]
    moved_target: list[float] | None
    """Where the exception moves the target (None: no exception)."""
    render_rgbd: bool | None = None
    image_size: tuple[int, int] | None = None
    """Width, height of the camera's images when it renders."""

    @model_serializer(mode="wrap")
    def _camera_when_rendering(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        out: dict[str, Any] = handler(self)
        if not self.render_rgbd:
            out.pop("render_rgbd", None)
            out.pop("image_size", None)
        return out


class TargetMoved(BaseModel):
    """The exception as it happened: the target moved when the robot came near it."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    type: str = "target_moved"
    step: int
    at: list[float]
    """Where the robot was (x, y)."""
    to: list[float]
    """Where the target went (x, y)."""


class SanityOutcome(EpisodeOutcome):
    """What a sanity episode achieved (the defaults: an episode in which nothing happened)."""

    target_initial: list[float] | None = None
    target_final: list[float] | None = None
    exception: TargetMoved | None = None
    reached: bool = False
    reached_step: int | None = None
    found_in_explore: bool = False
    reach_start: list[float] | None = None
    """Where the robot was when ``reach`` began."""
    reach_path: float = 0.0
    """Metres driven during ``reach``."""
    collisions: int = 0
    steps: int = 0


def _tensor(name: str, shape: tuple[int, ...], low: float, high: float, text: str) -> FieldSpec:
    return FieldSpec(name=name, dtype="float32", shape=shape, low=low, high=high, tensor=True,
                     description=text)


class SanityEpisode(TrackEpisode):
    """One live sanity episode around ``SanityArenaEnv``."""

    def __init__(self, scenario: Scenario[SanityScenario], hidden: SanityScenario) -> None:
        from simhost.worlds.sanity import HALF, MAX_DEPTH, SENSE_RADIUS, SanityArenaEnv

        self.scenario = scenario
        render = bool(hidden.render_rgbd)
        w, h = hidden.image_size or (64, 64)
        self.env = SanityArenaEnv(render_rgbd=render, image_size=(w, h))
        self.observation_spec = (
            _tensor("position", (2,), -HALF, HALF,
                    "robot x, y in the arena frame (m; origin at the centre, walls at ±2)"),
            _tensor("velocity", (2,), -5, 5, "robot velocity x, y (m/s)"),
            _tensor("target_visible", (1,), 0, 1,
                    f"1.0 when the target is within {SENSE_RADIUS} m, else 0.0"),
            _tensor("target_rel", (2,), -2 * HALF, 2 * HALF,
                    "target minus robot position x, y (m) when visible, else 0, 0"),
        )
        if render:
            n_ids = self.env.model.ngeom + self.env.model.nsite
            self.observation_spec += (
                FieldSpec(name="rgb", dtype="uint8", shape=(h, w, 3), low=0, high=255,
                          tensor=True, description="overhead camera colour image, row 0 at "
                          "+y (north)"),
                FieldSpec(name="depth", dtype="float32", shape=(h, w), low=0, high=MAX_DEPTH,
                          tensor=True, description=f"overhead camera depth (m from the "
                          f"camera; {MAX_DEPTH:g} where nothing is seen)"),
                FieldSpec(name="segmentation", dtype="int32", shape=(h, w), low=-1,
                          high=n_ids - 1, tensor=True, description="overhead camera: id of "
                          "the thing seen (target: the largest id), -1 for nothing"),
            )
        self.action_spec = (
            FieldSpec(name="velocity", dtype="float32", shape=(2,), low=-1.0, high=1.0,
                      description="desired robot velocity x, y as a fraction of 1 m/s; "
                      "applied for 0.1 s"),
        )
        self._start = np.asarray(hidden.start)
        self._target = np.asarray(hidden.target)
        self._moved_to = None if hidden.moved_target is None else np.asarray(hidden.moved_target)
        self._steps = 0
        self._stage_steps: dict[str, int] = {}
        self._found_in_explore = False
        self._exception: TargetMoved | None = None
        self._reach_start: list[float] | None = None
        self._reach_path = 0.0
        self._reached_step: int | None = None
        self._obs: dict[str, np.ndarray] = {}

    def reset(self) -> Observation:
        self._obs, _ = self.env.reset(
            seed=self.scenario.seed, options={"start": self._start, "target": self._target}
        )
        return self.observe()

    def observe(self) -> Observation:
        return Observation(tensors=self._obs)

    def on_stage_start(self, stage: str) -> tuple[HostMessage, ...]:
        if stage == "reach":
            self._reach_start = self.env.position.tolist()
            return (HostMessage(type="instruction", data={"text": "go to the target"}),)
        return (HostMessage(type="instruction", data={"text": "find the target and map it"}),)

    def on_stage_end(
        self, stage: str, *, ended_by: StageEnd, payload: Mapping[str, Any]
    ) -> tuple[Mapping[str, Any], ...]:
        return ()

    def step(self, stage: str, action: Mapping[str, Any]) -> StepOutcome:
        velocity = action.get("velocity")
        if velocity is None:
            return StepOutcome(
                observation=self.observe(),
                action=ActionResult(applied=False, ok=False, reason="no velocity given"),
            )
        self._steps += 1
        self._stage_steps[stage] = self._stage_steps.get(stage, 0) + 1
        before = self.env.position
        self._obs, _, reached, _, _ = self.env.step(np.asarray(velocity))
        events: list[dict[str, Any]] = []
        if stage == "explore" and self.env.target_visible():
            self._found_in_explore = True
        if stage == "reach":
            self._reach_path += float(np.linalg.norm(self.env.position - before))
            near = self.env.distance_to_target() < TRIGGER_RADIUS
            if near and self._moved_to is not None and self._exception is None:
                self._exception = TargetMoved(step=self._steps, at=self.env.position.tolist(),
                                              to=self._moved_to.tolist())
                self.env.move_target(self._moved_to)
                self._obs = self.env._obs()  # the effect is observable in this very reply
                events.append({"event": "exception", **self._exception.model_dump()})
                reached = False
            if reached:
                self._reached_step = self._steps
                return StepOutcome(
                    observation=self.observe(),
                    action=ActionResult(applied=True, ok=True),
                    episode_over=True,
                    end_reason=EndReason.COMPLETED,
                    events=({"event": "task_completed", "step": self._steps},),
                )
        return StepOutcome(
            observation=self.observe(),
            action=ActionResult(applied=True, ok=True),
            events=tuple(events),
        )

    def sim_state(self) -> bytes:
        return self.env.get_state()

    def poses(self) -> Mapping[str, Pose]:
        x, y = self.env.position
        tx, ty = self.env.target
        return {"robot": Pose(position=(float(x), float(y), 0.1)),
                "target": Pose(position=(float(tx), float(ty), 0.02))}

    def state_hash(self) -> str:
        return self.env.state_hash()

    def outcome(self) -> SanityOutcome:
        return SanityOutcome(
            target_initial=self._target.tolist(),
            target_final=self.env.target.tolist(),
            exception=self._exception,
            reached=self._reached_step is not None,
            reached_step=self._reached_step,
            found_in_explore=self._found_in_explore,
            reach_start=self._reach_start,
            reach_path=self._reach_path,
            collisions=self.env.collisions,
            sim_warnings=self.env.sim_warnings,
            steps=self._steps,
        )

    def close(self) -> None:
        self.env.close()


def _target_error(model: WorldModel | None, truth: list[float] | None) -> float | None:
    if model is None or truth is None:
        return None
    for obj in model.objects:
        if str(obj.id) == "target" and obj.position is not None:
            return float(np.linalg.norm(np.asarray(obj.position) - np.asarray(truth)))
    return None


def _closeness(err: float | None) -> float:
    return 0.0 if err is None else max(0.0, 1.0 - err / MODEL_TOLERANCE)


class SanityTrack(TrackPlugin[SanityScenario, SanityOutcome]):
    name = "sanity"
    title = "Sanity: find and reach a target in an arena (pipeline checks)"
    weights = {"task": 0.40, "model": 0.20, "recovery": 0.20, "efficiency": 0.10, "safety": 0.10}
    files = {
        "world_model.json": FileRule(WorldModel),
        EPISODE_LOG: FileRule(None, jsonl=True),
    }
    splits = {
        "standard": (0.6, {"exception_probability": 0.5}),
        "challenge": (0.4, {"exception_probability": 1.0}),
    }
    scenario_model = SanityScenario
    outcome_model = SanityOutcome

    def stages(self) -> list[StageSpec]:
        return [
            StageSpec("explore", budget_s=60.0, description="find the target and map it"),
            StageSpec("reach", budget_s=60.0, description="drive onto the target"),
        ]

    def make_scenario(
        self, *, seed: int, split: str, params: Mapping[str, Any], index: int | None = None
    ) -> Scenario[SanityScenario]:
        from simhost.worlds.sanity import sample_point

        sp = SanitySplitParams.model_validate({**self.splits.get(split, (1.0, {}))[1],
                                               **params})
        rng = np.random.default_rng(seed)
        start = sample_point(rng)
        target = sample_point(rng)
        while np.linalg.norm(target - start) < 1.5:
            target = sample_point(rng)
        moved = None
        if rng.random() < sp.exception_probability:
            moved = sample_point(rng)
            while np.linalg.norm(moved - target) < 1.0:
                moved = sample_point(rng)
        return self.new_scenario(seed=seed, split=split, hidden=SanityScenario(
            start=start.tolist(), target=target.tolist(),
            moved_target=None if moved is None else moved.tolist(),
            render_rgbd=sp.render_rgbd or None,
            image_size=sp.image_size if sp.render_rgbd else None))

    def picture(self, episode_dir: Path, out: Path | None = None) -> Path:
        """The arena from above: the robot's path by stage, its start and the target."""
        path = path_png(episode_dir)
        if out is not None and out != path:
            out.parent.mkdir(parents=True, exist_ok=True)
            path = path.replace(out)
        return path

    def make_episode(self, scenario: Scenario[SanityScenario]) -> TrackEpisode:
        return SanityEpisode(scenario, self.hidden(scenario))

    def score(self, data: ScoringInput[SanityScenario, SanityOutcome]) -> ScoreCard:
        o = self.outcome_of(data)
        o = SanityOutcome() if o is None else o  # None: the episode produced no outcome
        exc = o.exception
        final_model = data.file("world_model.json", WorldModel)
        explore_model = data.snapshot("explore", "world_model.json", WorldModel)
        log = data.log()
        reached = o.reached

        explore_err = _target_error(explore_model, o.target_initial)
        subgoals = [o.found_in_explore, explore_err is not None and explore_err < 0.3, reached]
        task = 0.6 * reached + 0.4 * float(np.mean(subgoals))

        model = _closeness(explore_err)
        if exc is not None:
            model = 0.5 * model + 0.5 * _closeness(_target_error(final_model, o.target_final))

        components = {"task": task, "model": model}
        weights = dict(self.weights)
        notes: list[str] = []
        if exc is not None:
            detected = any(
                r.event == "exception_detected"
                and r.exception_type == "target_moved"
                and exc.step <= r.step <= exc.step + DETECT_WINDOW
                for r in log
            )
            updated = _closeness(_target_error(final_model, o.target_final)) > 0.4
            components["recovery"] = (detected + updated + reached) / 3
        else:
            # No exception: its weight is spread over the other components in proportion.
            w = weights.pop("recovery")
            rest = sum(weights.values())
            weights = {k: v + w * v / rest for k, v in weights.items()}
            notes.append("no exception in this episode: recovery weight redistributed")

        start = o.reach_start
        if reached and start is not None and o.target_final is not None:
            if exc is None:
                optimal = float(np.linalg.norm(np.subtract(o.target_final, start)))
            else:
                optimal = float(np.linalg.norm(np.subtract(exc.at, start))) + float(
                    np.linalg.norm(np.subtract(o.target_final, exc.at))
                )
            components["efficiency"] = optimal / max(optimal, o.reach_path, 1e-9)
        else:
            components["efficiency"] = 0.0

        steps = max(1, data.steps)
        bad = data.invalid_actions + data.protocol_errors + o.collisions
        components["safety"] = max(0.0, 1.0 - 4.0 * bad / steps) if data.steps else 0.0

        total = float(sum(weights[k] * components[k] for k in weights))
        metrics = {
            "task_success": float(reached),
            "model_verification": model,
            "invalid_actions": float(data.invalid_actions + data.protocol_errors),
        }
        if "recovery" in components:
            metrics["recovery"] = components["recovery"]
        return ScoreCard(
            track=self.name,
            total=min(1.0, max(0.0, total)),
            components=components,
            weights=weights,
            metrics=metrics,
            notes=tuple(notes) + tuple(
                n for n in (ignored_note(name, parsed) for name, parsed in data.files.items())
                if n is not None),
        )
