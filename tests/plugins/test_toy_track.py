"""A third track from ``tests/`` alone (``_toy_track.py``): registered for this module
only, it gets a leaderboard, viewer pages, an audit and a protocol section, and passes both
conformance suites, without a file of eagc naming it; outside the registration nothing of
eagc sees it."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from _toy_track import ToyTrack

from orchestrator.conformance import TrackEpisodeConformance
from plugins import PluginError, TrackPlugin, available_tracks, load_track, registered_track
from plugins.conformance import TrackConformance

AGENT = f"{sys.executable} {Path(__file__).with_name('_toy_agent.py')}"


@pytest.fixture(scope="module", autouse=True)
def toy() -> Iterator[TrackPlugin]:
    with registered_track("toy", ToyTrack) as plugin:
        yield plugin
    assert "toy" not in available_tracks()


class TestToyConformance(TrackConformance):
    track = "toy"


class TestToyEpisodes(TrackEpisodeConformance):
    track = "toy"
    agent = AGENT

    def test_its_own_parts_show(self) -> None:
        from orchestrator._episode.audit import audit_episode
        from orchestrator._viewer.episode import read_episode

        for folder in self.played().folders:
            checks = {f.check for f in audit_episode(folder).findings}
            assert "goal_seen" in checks and "early_goal" not in checks, checks
            team, organizer = (read_episode(folder, organizer=o) for o in (False, True))
            assert team.map_image and organizer.map_image and team.map_image != organizer.map_image
            assert [p["caption"] for p in team.pictures] == ["the walk"]
            assert organizer.truth[0].startswith("goal at ") and not team.truth
            assert organizer.truth_of == "episode_log.jsonl"


def test_the_registration_lasts_for_its_block_only(toy: TrackPlugin) -> None:
    assert load_track("toy") is toy and "toy" in available_tracks()
    with pytest.raises(PluginError, match="already registered"):
        with registered_track("toy", ToyTrack):
            pass
    with pytest.raises(PluginError, match="already registered"):
        with registered_track("sanity", ToyTrack):
            pass
    with pytest.raises(PluginError, match="registered as 'corridor'"):
        with registered_track("corridor", ToyTrack):  # its name is "toy": not valid there
            pass
    assert "corridor" not in available_tracks()
    with pytest.raises(PluginError, match="no track named 'corridor'"):
        load_track("corridor")


def test_eagc_outside_the_test_never_sees_it() -> None:
    code = "from plugins import available_tracks; print(available_tracks())"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert "'sanity'" in out and "toy" not in out, out


def test_a_hook_that_takes_other_arguments_is_refused_on_load() -> None:
    class Mistaken(ToyTrack):
        name = "mistaken"

        def vocabulary(self, lang: str) -> str:  # type: ignore[override]
            return lang

    with pytest.raises(PluginError, match=r"hook vocabulary\(self, lang\) does not take the "
                       r"arguments of TrackPlugin.vocabulary\(self\)"):
        with registered_track("mistaken", Mistaken):
            pass
