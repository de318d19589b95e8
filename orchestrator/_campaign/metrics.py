"""Prometheus metrics of a campaign, served by the driver (docs/architecture.md, 'Observability').

Ray worker processes are short-lived and would each bind a port of their own, so nothing is
exported from them: the driver feeds these metrics from the results the tasks return and
from the live "started" reports workers send it. Every metric carries the ``campaign`` label.

========================================================  ==========  =======================
metric                                                    type        labels (plus campaign)
========================================================  ==========  =======================
``eagc_campaign_info``                                    gauge       track, phase
``eagc_campaign_episodes``                                gauge       state: planned, done,
                                                                      failed, quarantined,
                                                                      remaining
``eagc_campaign_last_progress_timestamp_seconds``         gauge
``eagc_episodes_running``                                 gauge
``eagc_episodes_total``                                   counter     submission, split, status
``eagc_episode_retries_total``                            counter     submission
``eagc_episodes_quarantined_total``                       counter     submission
``eagc_episode_duration_seconds``                         histogram   status
``eagc_agent_step_latency_seconds``                       histogram   submission
``eagc_invalid_actions_total``                            counter     submission
``eagc_episode_score``                                    histogram   submission, split
``eagc_container_peak_memory_bytes``                      histogram   submission
``eagc_containers_reaped_total``                          counter
``eagc_store_errors_total``                               counter
========================================================  ==========  =======================

Every labelled series exists from the campaign's start, at 0, for each submission, split
and status (``start_series``): a series that appeared only at its first increment would
hide that increment from ``increase()`` and from the alerts built on it.

``eagc_agent_step_latency_seconds`` observes each episode's median decision latency (the
time from a reply to the agent's next request).
"""

from __future__ import annotations

import time
from typing import Any

from prometheus_client import (
    CollectorRegistry,
    Counter,
    Gauge,
    Histogram,
    generate_latest,
    start_http_server,
)

from schemas import EpisodeResult

_DURATION = (1, 2, 5, 10, 20, 30, 60, 120, 300, 600, 1200, 1800, 3600, 7200)
_LATENCY = (0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5, 10, 30)
_SCORE = tuple(i / 10 for i in range(1, 11))
_MEMORY = tuple(float(2**n) for n in range(24, 36))  # 16 MiB … 32 GiB


class CampaignMetrics:
    """A campaign's metrics in a registry of their own, optionally served over HTTP."""

    def __init__(self, campaign: str, *, track: str, phase: str) -> None:
        self.campaign = campaign
        self.registry = CollectorRegistry(auto_describe=True)
        r = self.registry
        c = ("campaign",)
        Gauge("eagc_campaign_info", "The campaign being run (value 1).",
              (*c, "track", "phase"), registry=r).labels(campaign, track, phase).set(1)
        self.episodes = Gauge("eagc_campaign_episodes", "Episodes of the campaign by state "
                              "(from the results store).", (*c, "state"), registry=r)
        self.last_progress = Gauge(
            "eagc_campaign_last_progress_timestamp_seconds",
            "When an episode last started or finished (Unix time).", c, registry=r)
        self.running = Gauge("eagc_episodes_running", "Episodes running now.", c, registry=r)
        self.finished = Counter("eagc_episodes", "Episodes finished, by final status.",
                                (*c, "submission", "split", "status"), registry=r)
        self.retries = Counter("eagc_episode_retries", "Infrastructure failures retried.",
                               (*c, "submission"), registry=r)
        self.quarantined = Counter("eagc_episodes_quarantined",
                                   "Episodes held back after their last retry failed.",
                                   (*c, "submission"), registry=r)
        self.duration = Histogram("eagc_episode_duration_seconds", "Episode wall time.",
                                  (*c, "status"), buckets=_DURATION, registry=r)
        self.latency = Histogram("eagc_agent_step_latency_seconds",
                                 "Median agent decision latency of each episode.",
                                 (*c, "submission"), buckets=_LATENCY, registry=r)
        self.invalid = Counter("eagc_invalid_actions", "Invalid actions and protocol errors.",
                               (*c, "submission"), registry=r)
        self.score = Histogram("eagc_episode_score", "Episode score in [0, 1].",
                               (*c, "submission", "split"), buckets=_SCORE, registry=r)
        self.memory = Histogram("eagc_container_peak_memory_bytes",
                                "Peak memory of each agent container (cgroup).",
                                (*c, "submission"), buckets=_MEMORY, registry=r)
        self.reaped = Counter("eagc_containers_reaped", "Agent containers removed because "
                              "their episode was dead (stale heartbeat, killed worker, "
                              "cancelled campaign).", c, registry=r)
        self.store_errors = Counter("eagc_store_errors", "Writes to the results store that "
                                    "failed (a full disk, an I/O error).", c, registry=r)
        self.reaped.labels(campaign)
        self.store_errors.labels(campaign)
        self.running.labels(campaign).set(0)
        self._running = 0
        self.last_progress.labels(campaign).set(time.time())
        self._server: Any = None
        self._thread: Any = None

    # ------------------------------------------------------------------ serving
    def serve(self, port: int, addr: str = "0.0.0.0") -> int:
        """Serves ``/metrics`` on ``port`` (0: any free port); returns the port."""
        self._server, self._thread = start_http_server(port, addr, registry=self.registry)
        return int(self._server.server_port)

    def close(self) -> None:
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
            self._server = None

    def exposition(self) -> bytes:
        return generate_latest(self.registry)

    def start_series(self, spec: Any) -> None:
        """Every labelled series of ``spec``'s submissions, splits and statuses, at 0."""
        from schemas import EpisodeStatus

        c = self.campaign
        for state in ("planned", "done", "failed", "quarantined", "remaining"):
            self.episodes.labels(c, state).set(0)
        for status in EpisodeStatus:
            self.duration.labels(c, status.value)
        for sub in spec.submissions:
            team = sub.team
            for split in spec.splits:
                self.score.labels(c, team, split.name)
                for status in EpisodeStatus:
                    self.finished.labels(c, team, split.name, status.value)
            for metric in (self.retries, self.quarantined, self.latency, self.invalid,
                           self.memory):
                metric.labels(c, team)

    # ------------------------------------------------------------------ updates
    def set_states(self, states: dict[str, int]) -> None:
        for state, n in states.items():
            self.episodes.labels(self.campaign, state).set(n)

    def progress(self) -> None:
        self.last_progress.labels(self.campaign).set(time.time())

    def set_running(self, n: int) -> None:
        """The number of running episodes; a change counts as progress."""
        if n != self._running:
            self._running = n
            self.running.labels(self.campaign).set(n)
            self.progress()

    def episode_finished(self, submission: str, result: EpisodeResult) -> None:
        c, s = self.campaign, result.stats
        self.finished.labels(c, submission, result.split, result.status.value).inc()
        self.duration.labels(c, result.status.value).observe(s.wall_s)
        if s.latency_ms_median is not None:
            self.latency.labels(c, submission).observe(s.latency_ms_median / 1000)
        bad = s.invalid_actions + sum(
            n for code, n in s.protocol_errors.items() if code != "invalid_action")
        self.invalid.labels(c, submission).inc(bad)
        self.score.labels(c, submission, result.split).observe(result.score.total)
        if s.peak_memory_bytes:
            self.memory.labels(c, submission).observe(s.peak_memory_bytes)
        self.progress()

    def episode_retried(self, submission: str) -> None:
        self.retries.labels(self.campaign, submission).inc()
        self.progress()

    def containers_reaped(self, n: int) -> None:
        self.reaped.labels(self.campaign).inc(n)

    def store_error(self) -> None:
        self.store_errors.labels(self.campaign).inc()

    def episode_quarantined(self, submission: str) -> None:
        self.quarantined.labels(self.campaign, submission).inc()
        self.progress()
