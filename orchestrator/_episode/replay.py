"""Replaying an episode from its MCAP log (``eagc replay --verify``).

The log holds the hidden scenario, every request the episode applied (in order, with the
checked action), the stage events, and the simulator's state hash after every step (the full
state every N steps). Replaying feeds the same inputs to a fresh episode of the same track
in the same order and compares the state after each step, bit for bit. It tells a host bug
(the replay diverges or crashes where the live run did) from an agent that misbehaved (the
replay matches), and it is how an organizer audits a top submission's run.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.reader import make_reader

from orchestrator._errors import OrchestratorError
from plugins import Scenario, load_track
from simhost._actions import check_action
from simhost._episode import Observation

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


def _messages(path: Path) -> list[tuple[str, dict[str, Any] | bytes]]:
    out: list[tuple[str, dict[str, Any] | bytes]] = []
    with path.open("rb") as f:
        for _, channel, message in make_reader(f).iter_messages(
            topics=_TOPICS, log_time_order=True
        ):
            data = message.data if channel.topic == "/eagc/state" else json.loads(message.data)
            out.append((channel.topic, data))
    return out


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
    scen = next((d for t, d in messages if t == "/eagc/scenario"), None)
    if not isinstance(scen, dict):
        raise ReplayError(f"{path}: no /eagc/scenario message: not an eagc episode log")
    plugin = load_track(scen["track"])
    episode = plugin.make_episode(
        Scenario(track=scen["track"], split=scen["split"], seed=scen["seed"],
                 params=scen["params"])
    )
    report = ReplayReport(track=scen["track"], episode=scen["episode"])
    payload: dict[str, Any] = {}

    def mismatch(text: str) -> None:
        report.mismatches.append(text)

    try:
        for topic, data in messages:
            if len(report.mismatches) >= max_mismatches:
                break
            if topic == "/eagc/state":
                assert isinstance(data, bytes)
                if episode.sim_state() != data:
                    mismatch(f"full state differs after step {report.steps}")
                report.states_checked += 1
                continue
            assert isinstance(data, dict)
            if topic == "/eagc/request":
                kind, stage = data["kind"], data.get("stage")
                if kind == "reset":
                    shown(episode.reset())
                elif kind == "step":
                    action = check_action(episode.action_spec, data["action"])
                    out = episode.step(stage, action)
                    report.steps += 1
                    shown(out.observation)
                elif kind == "answer":
                    shown(episode.answer(stage, data["answers"]).observation)
                elif kind == "end_stage":
                    payload = data.get("payload") or {}
            elif topic == "/eagc/event":
                if data["event"] == "stage_start":
                    episode.on_stage_start(data["stage"])
                elif data["event"] == "stage_end":
                    ended_by = data["ended_by"]
                    episode.on_stage_end(data["stage"], ended_by=ended_by,
                                         payload=payload if ended_by == "agent" else {})
                    payload = {}
            elif topic == "/eagc/state_hash":
                report.hashes_checked += 1
                got = episode.state_hash()
                if got != data["hash"]:
                    mismatch(f"step {data['step']}: state hash {got}, logged {data['hash']}")
    finally:
        episode.close()
    return report
