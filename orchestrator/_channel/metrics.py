"""The channel's Prometheus metrics (``GET /metrics`` on the API; alert rules in
``deploy/prometheus/alerts.yml``, group ``eagc-channel``).

What is in the database is read at each scrape (a collector), so a restarted channel
reports the same figures as before its restart; durations are histograms observed as
runners report. Series::

    eagc_channel_submissions{phase,state}          submissions by state
    eagc_channel_queue_length                      submissions queued now
    eagc_channel_queue_oldest_age_seconds          how long the oldest queued one has waited
    eagc_channel_last_run_end_timestamp_seconds    when a run last ended (scored or failed)
    eagc_channel_lease_expiries_total              leases that ran out (runners that died)
    eagc_channel_refunds_total                     submissions refunded (not charged)
    eagc_channel_registry_storage_bytes            the registry's storage on disk
    eagc_channel_preflight_seconds, eagc_channel_run_seconds   durations (histograms)
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

from orchestrator._channel.storage import disk_bytes
from schemas import SubmissionState

S = SubmissionState


class ChannelMetrics:
    """A Prometheus registry of the channel's series, read from its database."""

    def __init__(self, channel: Any) -> None:
        from prometheus_client import CollectorRegistry, Histogram

        self.channel = channel
        self.registry = CollectorRegistry()
        self.registry.register(_Collector(channel))
        buckets = (5, 15, 30, 60, 120, 300, 600, 1800, 3600, 7200, 14400)
        self.preflight = Histogram("eagc_channel_preflight_seconds",
                                   "Pre-flight durations as runners report them.",
                                   buckets=buckets, registry=self.registry)
        self.run = Histogram("eagc_channel_run_seconds", "Run durations as runners report them.",
                             buckets=buckets, registry=self.registry)

    def observe(self, kind: str, seconds: float | None) -> None:
        if seconds is not None:
            (self.preflight if kind == "preflight" else self.run).observe(seconds)

    def exposition(self) -> bytes:
        from prometheus_client import generate_latest

        return bytes(generate_latest(self.registry))


class _Collector:
    def __init__(self, channel: Any) -> None:
        self.channel = channel
        self._storage: tuple[float, int] = (0.0, 0)

    def describe(self) -> list[Any]:
        return []

    def collect(self) -> Iterator[Any]:
        from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily

        db = self.channel.db.db
        by_state = GaugeMetricFamily("eagc_channel_submissions", "Submissions by state.",
                                     labels=["phase", "state"])
        seen = {(p, s): n for p, s, n in db.execute(
            "SELECT phase, state, COUNT(*) FROM submissions GROUP BY phase, state")}
        for phase in self.channel.spec.phases:
            for state in S:
                by_state.add_metric([phase.name, state.value],
                                    seen.get((phase.name, state.value), 0))
        yield by_state
        queued = db.execute("SELECT COUNT(*), MIN(queued_at) FROM submissions WHERE state=?",
                            (str(S.QUEUED),)).fetchone()
        yield GaugeMetricFamily("eagc_channel_queue_length", "Submissions queued now.",
                                value=queued[0] or 0)
        now = self.channel.clock.now()
        yield GaugeMetricFamily("eagc_channel_queue_oldest_age_seconds",
                                "How long the oldest queued submission has waited.",
                                value=max(now - queued[1], 0.0) if queued[1] else 0.0)
        last = db.execute("SELECT MAX(updated_at) FROM submissions WHERE state IN (?, ?) "
                          "AND episodes_done > 0", (str(S.SCORED), str(S.FAILED))).fetchone()
        yield GaugeMetricFamily("eagc_channel_last_run_end_timestamp_seconds",
                                "When a run last ended (0: none yet).", value=last[0] or 0.0)
        expiries = db.execute("SELECT COALESCE(SUM(lease_expiries), 0) FROM submissions"
                              ).fetchone()[0]
        yield CounterMetricFamily("eagc_channel_lease_expiries", "Leases that ran out.",
                                  value=expiries)
        refunds = db.execute("SELECT COUNT(*) FROM submissions WHERE charged=0 AND "
                             "rerun_of IS NULL").fetchone()[0]
        yield CounterMetricFamily("eagc_channel_refunds", "Submissions refunded.",
                                  value=refunds)
        at, size = self._storage
        if time.monotonic() - at > 30:  # a walk of the storage, at most twice a minute
            size = disk_bytes(self.channel.data / "registry" / "storage")
            self._storage = (time.monotonic(), size)
        yield GaugeMetricFamily("eagc_channel_registry_storage_bytes",
                                "The registry's storage on disk.", value=size)
