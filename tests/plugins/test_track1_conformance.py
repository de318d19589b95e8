"""Track 1 passes the track plugin conformance suite (standard, challenge and vision)."""

from __future__ import annotations

from plugins.conformance import TrackConformance


class TestTrack1Conformance(TrackConformance):
    track = "track1"
    steps_per_stage = 15


class TestTrack1ChallengeConformance(TrackConformance):
    track = "track1"
    split = "challenge"
    seed = 7


class TestTrack1VisionConformance(TrackConformance):
    """The vision split: no detections, no segmentation, actions by pixel."""

    track = "track1"
    split = "vision"
    seed = 20102
    steps_per_stage = 10
