"""The one way an episode is scored (``score_episode``), against the budgets it was granted."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from plugins._base import OutcomeT, Scenario, ScenarioT, ScoringInput, TrackPlugin
from plugins._files import ParsedFile
from schemas import EndReason, EpisodeStatus, ScoreCard
from simhost.host import StageSpec


def granted_budgets(stages: Sequence[StageSpec], time_scale: float = 1.0) -> dict[str, float]:
    """Each stage's wall-clock budget as the sim host grants it (official × ``time_scale``)."""
    return {s.name: s.budget_s * time_scale for s in stages}


def score_episode(plugin: TrackPlugin[ScenarioT, OutcomeT], scenario: Scenario[ScenarioT] | None,
                  *, status: EpisodeStatus, end_reason: EndReason,
                  stages_reached: Sequence[str], outcome: OutcomeT | None,
                  files: Mapping[str, ParsedFile],
                  snapshots: Mapping[str, Mapping[str, ParsedFile]], steps: int,
                  invalid_actions: int, protocol_errors: int,
                  time_scale: float = 1.0) -> ScoreCard:
    """The one way an episode is scored: the worker and every benchmark harness call it.

    An episode that never started (no scenario, the agent never started, an
    infrastructure failure) gets a zero card saying why. Otherwise the plugin scores it
    against the budgets the episode was granted (official x ``time_scale``), and the card
    notes an agent failure, or a last stage that used up its step budget."""
    if scenario is None or status in (EpisodeStatus.AGENT_NO_START, EpisodeStatus.INFRA_ERROR):
        return ScoreCard(track=plugin.name, total=0.0,
                         components=dict.fromkeys(plugin.weights, 0.0),
                         weights=dict(plugin.weights), notes=(f"not scored: {status.value}",))
    card = plugin.score(ScoringInput(
        scenario=scenario, status=status, end_reason=end_reason,
        stages_reached=tuple(stages_reached), outcome=outcome, files=files,
        snapshots=snapshots, steps=steps, invalid_actions=invalid_actions,
        protocol_errors=protocol_errors,
        stage_budgets_s=granted_budgets(plugin.stages(), time_scale)))
    if status.failure_kind == "agent":
        note = f"agent failure: {status}"
    elif end_reason == EndReason.STEPS:
        last = stages_reached[-1] if stages_reached else "?"
        note = f"the last stage {last!r} used its step budget: the task is scored as far as it got"
    else:
        return card
    return card.model_copy(update={"notes": (*card.notes, note)})
