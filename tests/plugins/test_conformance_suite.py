"""The conformance suite itself: its action sampler, and that it catches broken plugins."""

from __future__ import annotations

import random
from collections.abc import Mapping
from typing import Any

import numpy as np
import pytest

from plugins import Scenario, ScoringInput, StepOutcome
from plugins.conformance import TrackConformance, sample_action
from plugins.sanity import SanityEpisode, SanityTrack
from schemas import FieldSpec, FileCheck, ScoreCard
from simhost.host._actions import check_action

SPEC = (
    FieldSpec(name="velocity", dtype="float32", shape=(2,), low=-1.0, high=1.0),
    FieldSpec(name="tiny", dtype="float32", low=0.1, high=0.1000001),
    FieldSpec(name="free", dtype="float64", shape=(3,)),
    FieldSpec(name="floor", dtype="int64", shape=(2, 2), low=-3),
    FieldSpec(name="ceiling", dtype="int32", high=7),
    FieldSpec(name="pixel", dtype="uint8", shape=(4, 4, 3), low=0, high=255),
    FieldSpec(name="wide", dtype="uint16", low=0, high=65535),
    FieldSpec(name="grip", dtype="bool", shape=(1,)),
    FieldSpec(name="primitive", dtype="int32", choices=("move", "open", "pick")),
    FieldSpec(name="targets", dtype="int64", shape=(2,), choices=("a", "b")),
    FieldSpec(name="room", dtype="str", choices=("kitchen", "hall")),
    FieldSpec(name="note", dtype="str"),
)


def test_sampled_actions_pass_the_hosts_action_check():
    rng = np.random.default_rng(0)
    for _ in range(300):
        action = sample_action(SPEC, rng)
        assert set(action) == {f.name for f in SPEC}
        checked = check_action(SPEC, action)
        assert checked["pixel"].shape == (4, 4, 3) and checked["pixel"].dtype == np.uint8
        assert np.all(np.abs(checked["velocity"]) <= 1.0)
        assert np.all(checked["floor"] >= -3) and checked["ceiling"] <= 7
        assert checked["room"] in ("kitchen", "hall")


def test_sampler_is_deterministic_for_a_seed():
    a = sample_action(SPEC, np.random.default_rng(3))
    b = sample_action(SPEC, np.random.default_rng(3))
    assert all(np.array_equal(np.asarray(a[k]), np.asarray(b[k])) for k in a)


# --------------------------------------------------------------------- broken plugins
class _WrongDtypeEpisode(SanityEpisode):
    def observe(self):
        obs = super().observe()
        return type(obs)(tensors={k: v.astype(np.float64) for k, v in obs.tensors.items()})


class _OutOfBoundsEpisode(SanityEpisode):
    def observe(self):
        obs = super().observe()
        return type(obs)(tensors={**obs.tensors, "target_visible": np.array([2.0], np.float32)})


class _MissingFieldEpisode(SanityEpisode):
    def observe(self):
        obs = super().observe()
        return type(obs)(tensors={k: v for k, v in obs.tensors.items() if k != "velocity"})


class _NoisyEpisode(SanityEpisode):
    def state_hash(self) -> str:
        return f"{random.random()}"


class _DictOutcomeEpisode(SanityEpisode):
    def outcome(self):  # the old mapping, not the track's outcome model
        return super().outcome().model_dump()


class _FragileEpisode(SanityEpisode):
    def step(self, stage: str, action: Mapping[str, Any]) -> StepOutcome:
        return super().step(stage, {"velocity": action["velocity"]})


def _track(episode: type | None = None, **overrides: Any) -> SanityTrack:
    class Broken(SanityTrack):
        pass

    if episode is not None:
        Broken.make_episode = (  # type: ignore[method-assign]
            lambda self, scenario: episode(scenario, self.hidden(scenario)))
    for name, value in overrides.items():
        setattr(Broken, name, value)
    return Broken()


def _unseeded_scenario(self, *, seed, split, params):
    return SanityTrack.make_scenario(self, seed=random.randrange(1 << 30), split=split,
                                     params=params)


def _stray_component(self, data: ScoringInput) -> ScoreCard:
    card = SanityTrack.score(self, data)
    return card.model_copy(update={"components": {**card.components, "style": 1.0},
                                   "weights": {**card.weights, "style": 0.0}})


def _out_of_range_component(self, data: ScoringInput) -> ScoreCard:
    card = SanityTrack.score(self, data)
    return card.model_copy(update={"components": {**card.components, "task": 1.5}})


def _untyped_scenario(self, *, seed, split, params, index=None):
    s = SanityTrack.make_scenario(self, seed=seed, split=split, params=params)
    return Scenario(track=s.track, split=s.split, seed=s.seed, params=s.params)


def _accepting_verify(self, files):
    return {}, [FileCheck(name=n, ok=True) for n in files]  # accepts anything


BROKEN = {
    "wrong dtype": (_track(_WrongDtypeEpisode), "test_reset_matches_the_observation_spec"),
    "out of bounds": (_track(_OutOfBoundsEpisode), "test_reset_matches_the_observation_spec"),
    "missing field": (_track(_MissingFieldEpisode), "test_random_actions_through_every_stage"),
    "noisy state hash": (_track(_NoisyEpisode), "test_state_hash_is_deterministic"),
    "step needs a field": (_track(_FragileEpisode), "test_refused_and_empty_requests_do_not_raise"),
    "unseeded scenario": (_track(make_scenario=_unseeded_scenario),
                          "test_scenario_is_deterministic"),
    "stray component": (_track(score=_stray_component), "test_score_of_an_agent_that_did_nothing"),
    "component > 1": (_track(score=_out_of_range_component),
                      "test_score_of_an_agent_that_never_started"),
    "accepts garbage": (_track(verify_files=_accepting_verify), "test_verify_files_with_garbage"),
    "outcome not typed": (_track(_DictOutcomeEpisode), "test_random_actions_through_every_stage"),
    "scenario not typed": (_track(make_scenario=_untyped_scenario),
                           "test_scenario_is_typed_and_reads_back_from_its_json"),
}


@pytest.mark.parametrize("case", BROKEN)
def test_suite_catches_a_broken_plugin(case):
    plugin, method = BROKEN[case]

    class Suite(TrackConformance):
        track = "sanity"

    Suite.plugin = property(lambda self: plugin)  # type: ignore[assignment]
    with pytest.raises((AssertionError, KeyError, ValueError)):
        getattr(Suite(), method)()
