"""Track 1 passes the track plugin conformance suite (both splits)."""

from __future__ import annotations

from plugins.conformance import TrackConformance


class TestTrack1Conformance(TrackConformance):
    track = "track1"
    steps_per_stage = 15


class TestTrack1ChallengeConformance(TrackConformance):
    track = "track1"
    split = "challenge"
    seed = 7
