"""Every labelled series of a campaign exists, at 0, from its start (issue 13 §10)."""

from __future__ import annotations

from prometheus_client.parser import text_string_to_metric_families

from orchestrator._campaign.metrics import CampaignMetrics
from schemas import CampaignSpec, EpisodeStatus

SPEC = CampaignSpec.model_validate({
    "name": "m1", "track": "sanity",
    "splits": [{"name": "standard", "episodes": 2}, {"name": "challenge", "episodes": 1}],
    "submissions": [{"team": "a", "image": "x"}, {"team": "b", "image": "y"}],
})


def _samples(metrics: CampaignMetrics) -> dict[tuple[str, frozenset[tuple[str, str]]], float]:
    text = metrics.exposition().decode()
    return {(s.name, frozenset(s.labels.items())): s.value
            for family in text_string_to_metric_families(text) for s in family.samples}


def test_every_series_starts_at_zero() -> None:
    metrics = CampaignMetrics("m1", track="sanity", phase="local")
    metrics.start_series(SPEC)
    got = _samples(metrics)
    for team in ("a", "b"):
        for split in ("standard", "challenge"):
            for status in EpisodeStatus:
                key = ("eagc_episodes_total", frozenset({
                    "campaign": "m1", "submission": team, "split": split,
                    "status": status.value}.items()))
                assert got.get(key) == 0.0, key
        for name in ("eagc_episode_retries_total", "eagc_episodes_quarantined_total",
                     "eagc_invalid_actions_total"):
            key = (name, frozenset({"campaign": "m1", "submission": team}.items()))
            assert got.get(key) == 0.0, key
    for state in ("planned", "done", "failed", "quarantined", "remaining"):
        assert got[("eagc_campaign_episodes",
                    frozenset({"campaign": "m1", "state": state}.items()))] == 0.0
    for name in ("eagc_containers_reaped_total", "eagc_store_errors_total"):
        assert got[(name, frozenset({"campaign": "m1"}.items()))] == 0.0
    metrics.containers_reaped(2)
    metrics.store_error()
    got = _samples(metrics)
    assert got[("eagc_containers_reaped_total", frozenset({"campaign": "m1"}.items()))] == 2
    assert got[("eagc_store_errors_total", frozenset({"campaign": "m1"}.items()))] == 1
