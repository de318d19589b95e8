"""``plugins.score_episode``: the one scoring path of the worker and the benchmarks."""

from __future__ import annotations

import pytest
from test_track2_scoring import outcome  # tests/plugins/test_track2_scoring.py

from plugins import load_track, score_episode
from schemas import EndReason, EpisodeStatus

TRACK = load_track("track2")


def _card(status: EpisodeStatus, end: EndReason, *, scale: float = 1.0, with_scenario=True):  # noqa: ANN001, ANN202
    scenario = TRACK.make_scenario(seed=0, split="standard", params={"demo_frames": False},
                                   index=0)
    return score_episode(
        TRACK, scenario if with_scenario else None, status=status, end_reason=end,
        stages_reached=("demonstration", "parsing", "execution"),
        outcome=outcome(won=1, adapt_s=60.0), files={}, snapshots={}, steps=100,
        invalid_actions=0, protocol_errors=0, time_scale=scale)


def test_an_episode_that_never_ran_gets_a_zero_card_saying_why() -> None:
    for status in (EpisodeStatus.AGENT_NO_START, EpisodeStatus.INFRA_ERROR):
        card = _card(status, EndReason.STARTUP_TIMEOUT)
        assert card.total == 0.0 and card.notes == (f"not scored: {status.value}",)
        assert set(card.components) == set(TRACK.weights)
    card = _card(EpisodeStatus.COMPLETED, EndReason.COMPLETED, with_scenario=False)
    assert card.total == 0.0


def test_notes_say_an_agent_failure_or_a_used_up_step_budget() -> None:
    assert "agent failure: agent_crash" in _card(EpisodeStatus.AGENT_CRASH,
                                                 EndReason.STOPPED).notes
    steps = _card(EpisodeStatus.COMPLETED, EndReason.STEPS).notes
    assert any("'execution' used its step budget" in n for n in steps)
    plain = _card(EpisodeStatus.COMPLETED, EndReason.COMPLETED).notes
    assert not any("step budget" in n or "agent failure" in n for n in plain)


def test_the_time_scale_sets_the_budgets_adaptation_is_measured_against() -> None:
    """60 s of adaptation: 0.4 x (1 - 60 / 1500) official, 0.4 x (1 - 60 / 150) at 0.1."""
    official = _card(EpisodeStatus.COMPLETED, EndReason.COMPLETED).components["adaptation"]
    scaled = _card(EpisodeStatus.COMPLETED, EndReason.COMPLETED, scale=0.1)
    assert official == pytest.approx(0.6 + 0.4 * (1 - 60 / 1500))
    assert scaled.components["adaptation"] == pytest.approx(0.6 + 0.4 * (1 - 60 / 150))
