"""The sanity track passes the track plugin conformance suite."""

from plugins.conformance import TrackConformance


class TestSanityConformance(TrackConformance):
    track = "sanity"


class TestSanityChallengeSplitConformance(TrackConformance):
    """The split where the controlled exception always happens."""

    track = "sanity"
    split = "challenge"
    seed = 5
