"""A toy third track defined in tests alone: a robot on a 10 m corridor must reach a goal.

It exists to show that a track enters eagc through its ``TrackPlugin`` only: registered for
a test (``plugins.registered_track``), it gets a leaderboard, viewer pages, an audit and a
protocol section without a line of eagc knowing its name. Every hook is used: the map (the
corridor, the goal drawn for organizers only), a picture of the walk, the model against the
truth, the audit's own check and a vocabulary. ``_toy_agent.py`` plays it.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any

import numpy as np

from plugins import (
    EPISODE_LOG,
    AuditInput,
    EpisodeChecks,
    EpisodeMap,
    EpisodeOutcome,
    FileRule,
    Finding,
    HiddenScenario,
    Observation,
    RecordedEpisode,
    Scenario,
    ScoringInput,
    StageSpec,
    StepOutcome,
    StepPicture,
    TrackEpisode,
    TrackPlugin,
    TruthReport,
)
from schemas import EndReason, FieldSpec, ScoreCard
from simhost import encode_png
from simhost.host._episode import Pose

LENGTH = 10.0
SIGHT = 2.0  # metres: the goal shows within this distance
REACH = 0.25
PX = 20  # pixels per metre on the map


class ToyScenario(HiddenScenario):
    """Where the robot starts and where the goal is (hidden)."""

    start: float
    goal: float


class ToyOutcome(EpisodeOutcome):
    reached: bool = False
    steps: int = 0


class ToyEpisode(TrackEpisode):
    observation_spec = (
        FieldSpec(name="position", dtype="float32", shape=(1,), low=0.0, high=LENGTH,
                  tensor=True),
        FieldSpec(name="goal_offset", dtype="float32", shape=(1,), low=-SIGHT, high=SIGHT,
                  tensor=True, description="the goal's offset when in sight, else 0"),
        FieldSpec(name="goal_visible", dtype="float32", shape=(1,), low=0.0, high=1.0,
                  tensor=True),
    )
    action_spec = (FieldSpec(name="move", dtype="float32", shape=(1,), low=-1.0, high=1.0,
                             description="drive by move × 0.5 m"),)

    def __init__(self, hidden: ToyScenario) -> None:
        self.hidden, self.x, self.steps, self.reached = hidden, hidden.start, 0, False

    def reset(self) -> Observation:
        self.x, self.steps, self.reached = self.hidden.start, 0, False
        return self.observe()

    def observe(self) -> Observation:
        offset = self.hidden.goal - self.x
        seen = abs(offset) <= SIGHT
        return Observation(tensors={
            "position": np.array([self.x], np.float32),
            "goal_offset": np.array([offset if seen else 0.0], np.float32),
            "goal_visible": np.array([float(seen)], np.float32)})

    def step(self, stage: str, action: Mapping[str, Any]) -> StepOutcome:
        move = float(np.asarray(action.get("move", [0.0]), np.float64).reshape(-1)[0])
        self.x = float(np.clip(self.x + 0.5 * move, 0.0, LENGTH))
        self.steps += 1
        self.reached = abs(self.hidden.goal - self.x) < REACH
        return StepOutcome(observation=self.observe(), episode_over=self.reached,
                           end_reason=EndReason.COMPLETED if self.reached else None)

    def poses(self) -> Mapping[str, Pose]:
        return {"robot": Pose((self.x, 0.0, 0.0))}

    def state_hash(self) -> str:
        return hashlib.sha256(repr((self.x, self.steps)).encode()).hexdigest()[:16]

    def outcome(self) -> ToyOutcome:
        return ToyOutcome(reached=self.reached, steps=self.steps)


class GoalClaims(EpisodeChecks):
    """The audit's own check: a goal claimed in the log before the goal was in sight."""

    def __init__(self) -> None:
        self.first_seen: int | None = None

    def observe(self, step: int, data: Mapping[str, Any], tensors: Mapping[str, Any]) -> None:
        seen = tensors.get("goal_visible")
        if seen is not None and float(np.asarray(seen).reshape(-1)[0]) > 0.5 \
                and self.first_seen is None:
            self.first_seen = step

    def findings(self, episode: AuditInput) -> list[Finding]:
        early = [r for r in episode.log if r.event == "model_update"
                 and (self.first_seen is None or r.step < self.first_seen)]
        out = [Finding(check="goal_seen", severity="note",
                       message=f"the goal was first in sight at step {self.first_seen}")]
        return out + [Finding(check="early_goal", severity="flag", step=r.step,
                              message=f"step {r.step}: the goal claimed before it was seen")
                      for r in early]


class ToyTrack(TrackPlugin[ToyScenario, ToyOutcome]):
    name = "toy"
    title = "Toy: reach the goal on a corridor (a track defined in tests)"
    weights = {"task": 1.0}
    files = {EPISODE_LOG: FileRule(None, jsonl=True)}
    splits = {"standard": (1.0, {})}
    scenario_model = ToyScenario
    outcome_model = ToyOutcome

    def stages(self) -> list[StageSpec]:
        return [StageSpec("walk", budget_s=30.0, description="walk to the goal")]

    def make_scenario(self, *, seed: int, split: str, params: Mapping[str, Any],
                      index: int | None = None) -> Scenario[ToyScenario]:
        rng = np.random.default_rng(seed)
        hidden = ToyScenario(start=round(float(rng.uniform(0, 2)), 3),
                             goal=round(float(rng.uniform(4, 9)), 3))
        return self.new_scenario(seed=seed, split=split, hidden=hidden)

    def make_episode(self, scenario: Scenario[ToyScenario]) -> TrackEpisode:
        return ToyEpisode(ToyScenario.of(scenario))

    def score(self, data: ScoringInput[ToyScenario, ToyOutcome]) -> ScoreCard:
        o = self.outcome_of(data) or ToyOutcome()
        return ScoreCard(track=self.name, total=float(o.reached),
                         components={"task": float(o.reached)}, weights=dict(self.weights),
                         metrics={"task_success": float(o.reached)})

    # ------------------------------------------------------------------------ hooks
    def audit(self) -> EpisodeChecks:
        return GoalClaims()

    def episode_map(self, episode: RecordedEpisode) -> EpisodeMap:
        rgb = np.full((40, int(LENGTH * PX) + 20, 3), 255, np.uint8)
        rgb[19:21, 10:-10] = 128
        if episode.organizer:  # the goal is hidden from a team's view
            goal = 10 + int(ToyScenario.of(episode.scenario).goal * PX)
            rgb[12:28, goal - 2:goal + 3] = (220, 0, 0)
        return EpisodeMap(rgb=rgb, ox=10.0, oy=20.0, scale=float(PX),
                          caption="the corridor" + ("" if episode.organizer
                                                    else " (the goal is not drawn)"))

    def step_pictures(self, episode: RecordedEpisode) -> list[StepPicture]:
        steps = _claims(episode)
        last = steps[-1][0] if steps else 0
        return [StepPicture(first_step=0, last_step=last, caption="the walk",
                            png=encode_png(np.full((8, 8, 3), 200, np.uint8)))]

    def truth(self, episode: RecordedEpisode) -> TruthReport:
        goal = ToyScenario.of(episode.scenario).goal
        claims = _claims(episode)
        said = f"the agent put it at {claims[-1][1]:.2f} m" if claims else "the agent said nothing"
        return TruthReport(of="episode_log.jsonl", lines=(f"goal at {goal:.2f} m; {said}",))

    def vocabulary(self) -> str:
        return "The corridor is 10 m long; the goal shows within 2 m (`goal_visible`)."


def _claims(episode: RecordedEpisode) -> list[tuple[int, float]]:
    """The agent's ``model_update`` records: (step, where it put the goal)."""
    log = episode.folder / "host" / "output" / EPISODE_LOG
    records = [json.loads(line) for line in log.read_text().splitlines()] if log.is_file() else []
    return [(r["step"], float(r["data"]["goal"])) for r in records
            if r.get("event") == "model_update"]
