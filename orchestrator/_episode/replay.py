"""Replaying an episode from its MCAP log (``eagc replay --verify``).

The log holds the hidden scenario, every request the episode applied (in order, with the
checked action), the stage events, and the simulator's state hash after every step (the full
state every N steps). Replaying feeds the same inputs to a fresh episode of the same track
in the same order and compares the state after each step, bit for bit. It tells a host bug
(the replay diverges or crashes where the live run did) from an agent that misbehaved (the
replay matches), and it is how an organizer audits a top submission's run.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from orchestrator._errors import OrchestratorError
from plugins import Scenario, load_track
from simhost.host import (
    AnswerRequest,
    EndStageRequest,
    FullState,
    McapRecordError,
    Observation,
    Record,
    ResetRequest,
    ScenarioRecord,
    StageEndEvent,
    StageStartEvent,
    StateHash,
    StepRequest,
    check_action,
    read_records,
)

_TOPICS = ["/eagc/scenario", "/eagc/request", "/eagc/event", "/eagc/state_hash", "/eagc/state"]


class ReplayError(OrchestratorError, RuntimeError):
    """Raised when a log cannot be replayed (missing scenario, unknown track, …)."""


@dataclass
class ReplayReport:
    """What the replay found."""

    track: str
    episode: str
    steps: int = 0
    hashes_checked: int = 0
    states_checked: int = 0
    mismatches: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.mismatches and self.hashes_checked == self.steps


def _messages(path: Path) -> list[Record]:
    try:
        return list(read_records(path, _TOPICS))
    except McapRecordError as e:
        raise ReplayError(str(e)) from None


def replay(mcap_path: Path | str, *, max_mismatches: int = 5,
           on_observation: Callable[[int, Observation], None] | None = None) -> ReplayReport:
    """Re-simulates an episode from its log and checks every recorded state.

    ``on_observation(steps, observation)``, when given, sees each observation the replay
    makes (reset, step, answer), with the number of steps replayed so far: what the agent
    was shown, tensors too large for the log included.
    """

    def shown(observation: Observation) -> None:
        if on_observation is not None:
            on_observation(report.steps, observation)

    path = Path(mcap_path)
    messages = _messages(path)
    scen = next((r.body for r in messages if isinstance(r.body, ScenarioRecord)), None)
    if scen is None:
        raise ReplayError(f"{path}: no /eagc/scenario message: not an eagc episode log")
    plugin = load_track(scen.track)
    episode = plugin.make_episode(
        Scenario(track=scen.track, split=scen.split, seed=scen.seed, params=scen.params)
    )
    report = ReplayReport(track=scen.track, episode=scen.episode)
    payload: Mapping[str, Any] = {}

    def mismatch(text: str) -> None:
        report.mismatches.append(text)

    try:
        for record in messages:
            if len(report.mismatches) >= max_mismatches:
                break
            match record.body:
                case FullState(data=state):
                    if episode.sim_state() != state:
                        mismatch(f"full state differs after step {report.steps}")
                    report.states_checked += 1
                case ResetRequest():
                    shown(episode.reset())
                case StepRequest(stage=stage, action=action):
                    out = episode.step(stage, check_action(episode.action_spec, action))
                    report.steps += 1
                    shown(out.observation)
                case AnswerRequest(stage=stage, answers=answers):
                    shown(episode.answer(stage, answers).observation)
                case EndStageRequest(payload=given):
                    payload = given
                case StageStartEvent(stage=stage):
                    episode.on_stage_start(stage)
                case StageEndEvent(stage=stage, ended_by=ended_by):
                    episode.on_stage_end(stage, ended_by=ended_by,
                                         payload=payload if ended_by == "agent" else {})
                    payload = {}
                case StateHash(step=step, hash=logged):
                    report.hashes_checked += 1
                    got = episode.state_hash()
                    if got != logged:
                        mismatch(f"step {step}: state hash {got}, logged {logged}")
    finally:
        episode.close()
    return report
