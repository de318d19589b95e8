"""Track 1 episodes in one process: the sim host's rules without its transport.

``DirectEnv`` offers ``RemoteEnv``'s calls (hello, reset, step, answer, end_stage) and
serves them from a ``Track1Episode`` with the host's rules: stages in order, each stage's
step cap (the smaller of the episode's own step budget and an optional campaign-wide
cap), actions checked against the action spec (a bad one is an error reply, as
``HostError``), refused actions counted as invalid, ``/output`` snapshotted at every stage
end with the worker's own ``collect``, and the episode scored by the plugin from the same
``ScoringInput`` the worker builds. Observation data goes through a JSON round trip, as on
the wire. What it leaves out: Zenoh, the container, wall-clock budgets (stages are
step-capped here) and the MCAP log. ``tests/plugins/test_track1_harness.py`` checks that an
agent scores the same here as through the real worker.

``run_agent(agent_factory, split, seed)`` plays one episode and returns its ``Played``.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from orchestrator._episode.collect import collect
from plugins import load_track, score_episode
from plugins.track1 import Track1Episode
from schemas import (
    ActionResult,
    EpisodeStatus,
    HelloReply,
    HostMessage,
    Limits,
    ScoreCard,
    StageInfo,
)
from simhost.client import HostError, TimeStep
from simhost.host._actions import ActionError, check_action
from simhost.worlds.track1 import house_split

_LIMITS = Limits()


@dataclass
class Played:
    """One episode played in process."""

    split: str
    seed: int
    card: ScoreCard
    status: EpisodeStatus
    end_reason: str
    steps: int
    invalid_actions: int
    latencies_ms: list[float] = field(default_factory=list)
    error: str = ""
    exception: str | None = None
    snapshots: dict[str, dict[str, Any]] = field(default_factory=dict)
    """The parsed files of each stage-end snapshot (stage name → file name → model)."""
    planned: str | None = None
    """The type of the exception the scenario planned (None: none)."""


class DirectEnv:
    """``RemoteEnv``'s interface, served in process by a Track 1 episode (see the module)."""

    def __init__(self, episode: Track1Episode, stages: list[Any], output: Path, *,
                 max_steps_per_stage: int | None = None) -> None:
        self.episode = episode
        self.stages = stages
        self.output = output
        self.cap = max_steps_per_stage
        self.seq = 0
        self.stage = 0
        self.stage_steps = 0
        self.steps = 0
        self.invalid = 0
        self.over = False
        self.end_reason = ""
        self.stages_reached: list[str] = []
        self.snapshots: dict[str, dict[str, bytes]] = {}
        self.pending: list[HostMessage] = []
        self.latencies: list[float] = []
        self._replied_at: float | None = None

    # ------------------------------------------------------------------ host rules
    def _stage_cap(self, index: int) -> int | None:
        stage = self.stages[index]
        caps = [c for c in (stage.max_steps, self.cap, self.episode.step_budget(stage.name))
                if c is not None]
        return min(caps) if caps else None

    def _start_stage(self, index: int) -> None:
        self.stage, self.stage_steps = index, 0
        stage = self.stages[index]
        self.stages_reached.append(stage.name)
        self.pending.append(HostMessage(type="stage_started", data={
            "stage": stage.name, "index": index, "allows_motion": stage.allows_motion}))
        self.pending.extend(self.episode.on_stage_start(stage.name))

    def _end_stage(self, ended_by: str, payload: Mapping[str, Any]) -> None:
        name = self.stages[self.stage].name
        self.episode.on_stage_end(name, ended_by=ended_by, payload=payload)
        got = collect(self.output, max_file_bytes=_LIMITS.output_file_mb << 20,
                      max_total_bytes=_LIMITS.output_mb << 20)
        self.snapshots[name] = got.files

    def _advance(self, ended_by: str, payload: Mapping[str, Any] | None = None) -> None:
        self._end_stage(ended_by, payload or {})
        if self.stage + 1 < len(self.stages):
            self._start_stage(self.stage + 1)
        else:
            self.over = True
            self.end_reason = "completed" if ended_by == "agent" else ended_by

    def _reply(self, observation: Any, action: ActionResult | None) -> TimeStep:
        self.seq += 1
        data = json.loads(json.dumps(dict(observation.data)))
        messages = tuple(self.pending)
        self.pending.clear()
        cap = self._stage_cap(self.stage)
        stage = self.stages[self.stage]
        self._replied_at = time.perf_counter()
        return TimeStep(
            observation={**data, **observation.tensors}, stage=stage.name,
            stage_index=self.stage, time_left_s=0.0 if self.over else stage.budget_s,
            steps_left=None if cap is None else max(0, cap - self.stage_steps), action=action,
            messages=messages, episode_over=self.over,
            end_reason=self.end_reason if self.over else None, seq=self.seq)

    def _tick(self) -> None:
        if self._replied_at is not None:
            self.latencies.append((time.perf_counter() - self._replied_at) * 1000)
            self._replied_at = None
        if self.over:
            raise HostError("bad_order", "the episode is over", True)

    # ------------------------------------------------------------------ RemoteEnv's calls
    def hello(self, agent: str = "") -> HelloReply:
        return HelloReply(
            seq=1, episode="in-process", track="track1",
            observation_spec=self.episode.observation_spec,
            action_spec=self.episode.action_spec,
            stages=tuple(StageInfo(name=s.name, budget_s=s.budget_s,
                                   max_steps=self._stage_cap(k),
                                   allows_motion=s.allows_motion, description=s.description)
                         for k, s in enumerate(self.stages)),
            max_request_bytes=1 << 20, startup_budget_s=60.0)

    def reset(self) -> TimeStep:
        obs = self.episode.reset()
        self._start_stage(0)
        return self._reply(obs, None)

    def step(self, action: Mapping[str, Any]) -> TimeStep:
        self._tick()
        plain = {k: v.tolist() if isinstance(v, np.ndarray | np.generic) else v
                 for k, v in action.items()}
        try:
            checked = check_action(self.episode.action_spec, plain)
        except ActionError as e:
            self.invalid += 1
            raise HostError("invalid_action", str(e), False) from None
        self.steps += 1
        self.stage_steps += 1
        out = self.episode.step(self.stages[self.stage].name, checked)
        if out.action is not None and not out.action.ok:
            self.invalid += 1
        if out.episode_over:
            self._end_stage("episode_over", {})
            self.over, self.end_reason = True, out.end_reason or "completed"
        else:
            cap = self._stage_cap(self.stage)
            if cap is not None and self.stage_steps >= cap:
                self._advance("steps")
        return self._reply(out.observation, out.action)

    def answer(self, answers: Mapping[str, Any]) -> TimeStep:
        self._tick()
        out = self.episode.answer(self.stages[self.stage].name,
                                  json.loads(json.dumps(dict(answers))))
        return self._reply(out.observation, out.action)

    def end_stage(self, payload: Mapping[str, Any] | None = None) -> TimeStep:
        self._tick()
        self._advance("agent", json.loads(json.dumps(dict(payload or {}))))
        return self._reply(self.episode.observe(), None)

    def close(self) -> None:
        pass

    def __enter__(self) -> DirectEnv:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def run_agent(make_agent: Callable[[Track1Episode], Any], split: str, seed: int, *,
              max_steps_per_stage: int | None = None, params: Mapping[str, Any] | None = None,
              render: bool = True, index: int | None = None) -> Played:
    """Plays one episode with ``make_agent(episode).run(env)`` and scores it.

    ``render=False`` leaves the camera images out (none of the baselines reads them, and
    rendering changes nothing in the simulation; it is 2/3 of a step's cost). ``index``: the
    episode's index in its split, as a campaign gives it (the exception type comes from
    it); None: a one-off episode (the seed draws it)."""
    plugin = load_track("track1")
    merged = dict(params or {})
    if not render and house_split(split).config.actions_by == "id":  # pixels need frames
        merged["render_rgbd"] = False
    scenario = plugin.make_scenario(seed=seed, split=split, params=merged, index=index)
    episode = plugin.make_episode(scenario)
    assert isinstance(episode, Track1Episode)
    with tempfile.TemporaryDirectory(prefix="t1h-") as tmp:
        output = Path(tmp)
        env = DirectEnv(episode, plugin.stages(), output,
                        max_steps_per_stage=max_steps_per_stage)
        error = ""
        before = os.environ.get("EAGC_OUTPUT")
        os.environ["EAGC_OUTPUT"] = str(output)
        try:
            make_agent(episode).run(env)
        except Exception as e:  # noqa: BLE001 - an agent crash is scored, as the worker does
            error = f"{type(e).__name__}: {e}"
        finally:
            if before is None:
                os.environ.pop("EAGC_OUTPUT", None)
            else:
                os.environ["EAGC_OUTPUT"] = before
        if not env.over:
            if env.stages_reached and env.stages[env.stage].name not in env.snapshots:
                env._end_stage("stopped", {})
            env.end_reason = "stopped"
        final = collect(output, max_file_bytes=_LIMITS.output_file_mb << 20,
                        max_total_bytes=_LIMITS.output_mb << 20)
        parsed, checks = plugin.verify_files(final.files)
        snaps = {stage: plugin.parse_snapshot(files) for stage, files in env.snapshots.items()}
        if error or env.end_reason == "stopped":
            status = EpisodeStatus.AGENT_CRASH
        elif any(not c.ok for c in checks):
            status = EpisodeStatus.AGENT_BAD_FILES
        else:
            status = EpisodeStatus.COMPLETED
        outcome = episode.outcome()
        card = score_episode(
            plugin, scenario, status=status, end_reason=env.end_reason,
            stages_reached=env.stages_reached, outcome=outcome, files=parsed,
            snapshots=snaps, steps=env.steps, invalid_actions=env.invalid, protocol_errors=0)
    episode.close()
    exc = outcome.exception
    return Played(split=split, seed=seed, card=card, status=status, end_reason=env.end_reason,
                  steps=env.steps, invalid_actions=env.invalid, latencies_ms=env.latencies,
                  error=error, exception=None if exc is None else exc.type, snapshots=snaps,
                  planned=(scenario.params.get("exception") or {}).get("type"))


def median(values: list[float]) -> float:
    return float(np.median(values)) if values else math.nan
