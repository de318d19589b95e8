"""Track 2 runs the plugin conformance suite (``plugins.conformance``)."""

from __future__ import annotations

from plugins.conformance import TrackConformance


class TestTrack2Conformance(TrackConformance):
    track = "track2"
    params = {"demo_frames": False}
