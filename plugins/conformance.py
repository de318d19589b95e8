"""The conformance suite every track plugin must pass (like dm_env's ``EnvironmentTestMixin``).

Subclass it in a test module, naming the track by its entry-point name; pytest collects
the ``test_*`` methods::

    from plugins.conformance import TrackConformance

    class TestMyTrackConformance(TrackConformance):
        track = "my_track"

It drives the plugin the way the sim host and the episode worker do, without Zenoh: the
plugin loads and validates; its stages are sound; scenarios are deterministic per seed;
``reset()`` and every step return observations that match ``observation_spec``; random
valid actions drawn from ``action_spec`` run through every stage in the host's order
(``reset → on_stage_start → step… → on_stage_end → … → close``) and the state hash is
deterministic; ``verify_files`` turns any bytes into ``FileCheck``s and never raises; ``score``
gives a sound, deterministic ``ScoreCard`` even for an episode in which nothing happened.
The hooks: each one the plugin overrides takes ``TrackPlugin``'s arguments (checked on
load); ``audit()`` makes fresh checks that read an episode as ``eagc audit`` feeds it and
find the same on the same episode; ``vocabulary()`` is Markdown that cannot break the
protocol page's generated sections. The hooks that read a recorded episode (the viewer's
``episode_map``, ``step_pictures``, ``truth``; ``picture``) are checked on real episodes by
``orchestrator.conformance.TrackEpisodeConformance``.

Override the class attributes to fit a track (``seed``, ``split``, ``steps_per_stage``,
``valid_files`` when a file model has required fields). Requires pytest only to run.
"""

from __future__ import annotations

import functools
import json
import math
import pickle
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from plugins._audit import AuditInput, EpisodeChecks, Finding, HostSteps, Snapshot
from plugins._base import Scenario, ScoringInput, TrackPlugin
from plugins._files import ParsedFile
from plugins._registry import available_tracks, load_track, validate_plugin
from plugins._scoring import granted_budgets
from schemas import EndReason, EpisodeStatus, FieldSpec, FileCheck, HostMessage, ScoreCard
from simhost.host import (
    EpisodeOutcome,
    Observation,
    ScenarioRecord,
    StageSpec,
    StepOutcome,
    TrackEpisode,
    check_action,
)

__all__ = ["TrackConformance", "check_observation", "check_outcome", "sample_action"]

_WIRE_DTYPES = {"float32", "float64", "int32", "int64", "uint8", "uint16", "bool"}
_SPAN = 10.0  # sampling range on a side a spec leaves unbounded


def _sample_field(spec: FieldSpec, rng: np.random.Generator) -> Any:
    if spec.dtype == "str":
        if spec.choices:
            return str(rng.choice(list(spec.choices)))
        return "".join(rng.choice(list("abcdefgh _-"), size=int(rng.integers(0, 12))))
    shape = tuple(spec.shape)
    if spec.choices:
        index = rng.integers(0, len(spec.choices), size=shape)
        if not shape and rng.random() < 0.5:
            return spec.choices[int(index)]  # a choice may also be sent by its name
        return index.astype(spec.dtype)
    if spec.dtype == "bool":
        return rng.random(shape) < 0.5
    low, high = spec.low, spec.high
    if low is None and high is None:
        low, high = -_SPAN, _SPAN
    elif low is None:
        low = high - 2 * _SPAN  # type: ignore[operator]
    elif high is None:
        high = low + 2 * _SPAN
    kind = np.dtype(spec.dtype).kind
    if kind in "iu":
        info = np.iinfo(spec.dtype)
        lo, hi = max(math.ceil(low), info.min), min(math.floor(high), info.max)
        return rng.integers(lo, hi, size=shape, endpoint=True).astype(spec.dtype)
    # Draw in float64, then keep the bounds after rounding to the field's dtype.
    values = rng.uniform(low, high, size=shape).astype(spec.dtype)
    return np.clip(values, np.asarray(low, spec.dtype), np.asarray(high, spec.dtype))


def sample_action(spec: tuple[FieldSpec, ...], rng: np.random.Generator) -> dict[str, Any]:
    """A random action valid for ``spec``: every field, honouring dtype, shape, bounds, choices."""
    return {f.name: _sample_field(f, rng) for f in spec}


def check_observation(spec: tuple[FieldSpec, ...], obs: Observation, where: str) -> None:
    """Asserts that ``obs`` matches ``spec``: names, where they travel, dtypes, shapes, bounds."""
    assert isinstance(obs, Observation), f"{where}: returned {type(obs).__name__}, not Observation"
    names = [f.name for f in spec]
    assert len(set(names)) == len(names), f"observation_spec repeats names: {names}"
    given = set(obs.tensors) | set(obs.data)
    both = set(obs.tensors) & set(obs.data)
    assert not both, f"{where}: {sorted(both)} given both as tensors and as data"
    assert given == set(names), (
        f"{where}: observation has {sorted(given)}, observation_spec says {sorted(names)}"
    )
    try:
        json.dumps(dict(obs.data), allow_nan=False)
    except (TypeError, ValueError) as e:
        raise AssertionError(f"{where}: observation data must be plain JSON: {e}") from None
    for f in spec:
        if f.tensor:
            assert f.name in obs.tensors, f"{where}: {f.name!r} is a tensor field but came as data"
            value = obs.tensors[f.name]
            assert isinstance(value, np.ndarray), f"{where}: tensor {f.name!r} is not an ndarray"
            assert value.dtype.name in _WIRE_DTYPES and value.dtype.isnative, (
                f"{where}: tensor {f.name!r} has dtype {value.dtype}, not one protocol v1 carries"
            )
        else:
            assert f.name in obs.data, f"{where}: {f.name!r} is a JSON field but came as a tensor"
            value = obs.data[f.name]
        if f.dtype == "json":
            json.dumps(value, allow_nan=False)  # any plain JSON value, nothing else
            continue
        if f.dtype == "str":
            assert isinstance(value, str), f"{where}: {f.name!r} should be a string"
            assert f.choices is None or value in f.choices, f"{where}: {f.name!r}={value!r}"
            continue
        arr = np.asarray(value)
        assert arr.dtype.name == f.dtype or (not f.tensor and arr.dtype.kind in "biuf"), (
            f"{where}: {f.name!r} has dtype {arr.dtype}, observation_spec says {f.dtype}"
        )
        assert arr.shape == tuple(f.shape), (
            f"{where}: {f.name!r} has shape {arr.shape}, observation_spec says {tuple(f.shape)}"
        )
        if arr.dtype.kind == "f":
            assert np.all(np.isfinite(arr)), f"{where}: {f.name!r} holds NaN or Inf"
        if f.low is not None:
            assert np.all(arr >= f.low), f"{where}: {f.name!r} below its low {f.low}: {arr}"
        if f.high is not None:
            assert np.all(arr <= f.high), f"{where}: {f.name!r} above its high {f.high}: {arr}"
        if f.choices is not None:
            assert np.all((arr >= 0) & (arr < len(f.choices))), f"{where}: {f.name!r}={arr}"


def check_outcome(plugin: TrackPlugin[Any, Any], outcome: EpisodeOutcome) -> None:
    """Asserts that ``outcome`` is the plugin's ``outcome_model`` and survives its JSON."""
    model = plugin.outcome_model
    assert isinstance(outcome, model), (
        f"outcome() returned {type(outcome).__name__}, not the plugin's {model.__name__}")
    assert isinstance(outcome.sim_warnings, int) and outcome.sim_warnings >= 0
    back = model.model_validate_json(outcome.model_dump_json())
    assert back.model_dump(mode="json") == outcome.model_dump(mode="json"), (
        "the outcome does not read back from its JSON")


def _plain(value: Any) -> Any:
    """An action's value as the episode's log records it (plain JSON)."""
    if isinstance(value, np.ndarray | np.generic):
        return value.tolist()
    return value


@functools.cache
def _vocabulary(track: str) -> str:
    """The track's vocabulary, asked once per track (sampling scenarios can be slow)."""
    return load_track(track).vocabulary()


def _same(a: Any, b: Any) -> bool:
    """Equality that also holds for numpy arrays nested in mappings and sequences."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return bool(np.array_equal(np.asarray(a), np.asarray(b)))
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return bool(a == b)


class TrackConformance:
    """Checks one track plugin. Subclass it in a ``Test*`` class and set ``track``."""

    #: The entry-point name of the track under test.
    track: ClassVar[str]
    #: Scenario seed and split (None: the plugin's first split) used throughout.
    seed: ClassVar[int] = 20260
    split: ClassVar[str | None] = None
    #: Scenario parameters, as a campaign split would pass them.
    params: ClassVar[Mapping[str, Any]] = {}
    #: Random actions per stage in the episode runs.
    steps_per_stage: ClassVar[int] = 12
    #: A valid example of every collected file; None: built from each file model's defaults.
    valid_files: ClassVar[Mapping[str, bytes] | None] = None

    # ----------------------------------------------------------------------- helpers
    @property
    def plugin(self) -> TrackPlugin[Any, Any]:
        """The plugin under test, loaded through its entry point."""
        return load_track(self.track)

    def _split(self) -> str:
        return self.split if self.split is not None else next(iter(self.plugin.splits))

    def _scenario(self, seed: int | None = None) -> Scenario[Any]:
        return self.plugin.make_scenario(
            seed=self.seed if seed is None else seed, split=self._split(), params=self.params
        )

    def _run(self, actions_seed: int, checks: EpisodeChecks | None = None
             ) -> tuple[list[str], list[StepOutcome], TrackEpisode]:
        """Plays one episode the way the host does, feeding ``checks`` (a track's audit)
        what the agent is shown as ``eagc audit`` would; returns state hashes and
        outcomes."""
        plugin = self.plugin
        episode = plugin.make_episode(self._scenario())
        rng = np.random.default_rng(actions_seed)
        hashes: list[str] = []
        outcomes: list[StepOutcome] = []
        try:
            first = episode.reset()
            check_observation(episode.observation_spec, first, "reset()")
            if checks is not None:
                checks.observe(0, first.data, first.tensors)
            hashes.append(episode.state_hash())
            over = False
            for stage in plugin.stages():
                messages = episode.on_stage_start(stage.name)
                assert isinstance(messages, tuple) and all(
                    isinstance(m, HostMessage) for m in messages
                ), f"on_stage_start({stage.name!r}) must return a tuple of HostMessage"
                if checks is not None:
                    for m in messages:
                        checks.message(len(outcomes), m)
                for _ in range(self.steps_per_stage):
                    action = check_action(
                        episode.action_spec, sample_action(episode.action_spec, rng)
                    )
                    out = episode.step(stage.name, action)
                    where = f"step({stage.name!r}, {action})"
                    assert isinstance(out, StepOutcome), f"{where}: not a StepOutcome"
                    check_observation(episode.observation_spec, out.observation, where)
                    assert all(isinstance(m, HostMessage) for m in out.messages), where
                    assert all(isinstance(e, Mapping) for e in out.events), where
                    outcomes.append(out)
                    hashes.append(episode.state_hash())
                    if checks is not None:
                        self._feed(checks, len(outcomes), action, out)
                    if out.episode_over:
                        over = True
                        break
                ended_by = "episode_over" if over else "steps"
                events = episode.on_stage_end(stage.name, ended_by=ended_by, payload={})
                assert isinstance(events, tuple), f"on_stage_end({stage.name!r}): not a tuple"
                if over:
                    break
            check_observation(episode.observation_spec, episode.observe(), "observe()")
            check_outcome(self.plugin, episode.outcome())
        except BaseException:
            episode.close()
            raise
        return hashes, outcomes, episode

    @staticmethod
    def _feed(checks: EpisodeChecks, step: int, action: Mapping[str, Any],
              out: StepOutcome) -> None:
        checks.observe(step, out.observation.data, out.observation.tensors)
        for m in out.messages:
            checks.message(step, m)
        if out.action is not None:
            checks.action(step, {k: _plain(v) for k, v in action.items()}, out.action)

    def _audited(self, checks: EpisodeChecks) -> list[Finding]:
        """What ``checks`` find on an episode of random actions, with the example files."""
        _, outcomes, episode = self._run(actions_seed=3, checks=checks)
        episode.close()
        scenario = self._scenario()
        record = ScenarioRecord(episode="conformance", track=scenario.track,
                                split=scenario.split, seed=scenario.seed,
                                params=json.loads(json.dumps(dict(scenario.params))))
        steps = len(outcomes)
        return checks.findings(AuditInput(
            scenario=record, events=(), log=(), host=HostSteps(steps),
            snapshots=(Snapshot("final", steps, self._example_files()),)))

    def _scoring_input(self, *, started: bool) -> ScoringInput[Any, Any]:
        """An episode in which the agent did nothing (never started, or sat still)."""
        scenario = self._scenario()
        episode = self.plugin.make_episode(scenario)
        try:
            stages: tuple[str, ...] = ()
            if started:
                episode.reset()
                first = self.plugin.stages()[0].name
                episode.on_stage_start(first)
                episode.on_stage_end(first, ended_by="budget", payload={})
                stages = (first,)
            outcome = episode.outcome()
            check_outcome(self.plugin, outcome)
        finally:
            episode.close()
        return ScoringInput(
            scenario=scenario,
            status=EpisodeStatus.AGENT_TIMEOUT if started else EpisodeStatus.AGENT_NO_START,
            end_reason=EndReason.BUDGET if started else EndReason.STARTUP_TIMEOUT,
            stages_reached=stages,
            outcome=outcome,
            files={},
            snapshots={},
            steps=0,
            invalid_actions=0,
            protocol_errors=0,
            stage_budgets_s=granted_budgets(self.plugin.stages()),
        )

    def _example_files(self) -> dict[str, bytes]:
        if self.valid_files is not None:
            return dict(self.valid_files)
        out: dict[str, bytes] = {}
        for name, rule in self.plugin.files.items():
            if rule.jsonl:
                out[name] = b'{"step": 0, "event": "note", "data": {"text": "hello"}}\n'
            else:
                assert rule.model is not None, f"file {name!r}: a JSON rule needs a model"
                out[name] = rule.model().model_dump_json().encode()
        return out

    def _checks(self, files: Mapping[str, bytes]) -> tuple[dict[str, ParsedFile], list[FileCheck]]:
        parsed, checks = self.plugin.verify_files(files)
        assert all(isinstance(c, FileCheck) for c in checks)
        names = [c.name for c in checks]
        assert len(set(names)) == len(names), f"one check per file, got {names}"
        for c in checks:
            assert c.ok or c.reason, f"check of {c.name!r} failed without a reason"
            assert c.ok == (c.name in parsed), f"{c.name!r}: ok={c.ok}, parsed: {sorted(parsed)}"
        return parsed, checks

    # ------------------------------------------------------------------- the plugin
    def test_loads_and_validates(self):
        assert self.track in available_tracks(), f"{self.track!r} is not an installed track"
        plugin = load_track(self.track)
        assert isinstance(plugin, TrackPlugin)
        assert load_track(self.track) is plugin, "load_track should cache the plugin"
        validate_plugin(plugin, name=self.track)
        assert plugin.title and isinstance(plugin.title, str)

    def test_stages_are_sound(self):
        stages = self.plugin.stages()
        assert stages == self.plugin.stages(), "stages() must not change between calls"
        for s in stages:
            assert isinstance(s, StageSpec), f"{s!r} is not a StageSpec"
            assert s.name and s.name.strip() == s.name, f"stage name {s.name!r}"
            assert math.isfinite(s.budget_s) and s.budget_s > 0, f"{s.name}: {s.budget_s}"
            assert s.max_steps is None or s.max_steps >= 1, f"{s.name}: max_steps {s.max_steps}"

    def test_weights_files_and_splits_are_sound(self):
        plugin = self.plugin
        assert all(0 <= w <= 1 for w in plugin.weights.values()), dict(plugin.weights)
        for name, (weight, params) in plugin.splits.items():
            assert name and weight > 0, f"split {name!r} has weight {weight}"
            assert isinstance(params, Mapping)
        for name, rule in plugin.files.items():
            assert "/" not in name and not name.startswith("."), f"file name {name!r}"
            assert rule.jsonl or rule.model is not None, f"file {name!r} has no model"

    # -------------------------------------------------------------------- scenarios
    def test_scenario_is_deterministic(self):
        a, b = self._scenario(), self._scenario()
        assert isinstance(a, Scenario)
        assert (a.track, a.split, a.seed) == (self.plugin.name, self._split(), self.seed)
        assert _same(a.params, b.params), "the same seed gave two different scenarios"
        copy = pickle.loads(pickle.dumps(a))  # it travels to Ray workers
        assert _same(copy.params, a.params)

    def test_scenario_is_typed_and_reads_back_from_its_json(self):
        a = self._scenario()
        model = self.plugin.scenario_model
        assert isinstance(a.hidden, model), (
            f"make_scenario gave hidden={type(a.hidden).__name__}, not {model.__name__} "
            "(build it with TrackPlugin.new_scenario)")
        logged = json.loads(json.dumps(dict(a.params)))  # as the episode's log keeps it
        rebuilt = Scenario(track=a.track, split=a.split, seed=a.seed, params=logged)
        assert self.plugin.hidden(rebuilt) == a.hidden, "params do not read back as hidden"
        assert pickle.loads(pickle.dumps(a)).hidden == a.hidden

    def test_scenarios_differ_between_seeds(self):
        first = self._scenario().params
        others = [self._scenario(self.seed + k).params for k in range(1, 6)]
        assert not all(_same(first, o) for o in others), "five other seeds gave the same scenario"

    def test_every_split_makes_scenarios(self):
        for split in self.plugin.splits:
            s = self.plugin.make_scenario(seed=self.seed, split=split, params=self.params)
            assert s.split == split

    # ---------------------------------------------------------------------- episodes
    def test_reset_matches_the_observation_spec(self):
        episode = self.plugin.make_episode(self._scenario())
        try:
            for spec in (episode.observation_spec, episode.action_spec):
                assert spec and all(isinstance(f, FieldSpec) for f in spec)
            first = episode.reset()
            check_observation(episode.observation_spec, first, "reset()")
            check_observation(episode.observation_spec, episode.observe(), "observe()")
        finally:
            episode.close()

    def test_sampled_actions_are_valid(self):
        episode = self.plugin.make_episode(self._scenario())
        try:
            rng = np.random.default_rng(0)
            for _ in range(50):
                check_action(episode.action_spec, sample_action(episode.action_spec, rng))
        finally:
            episode.close()

    def test_random_actions_through_every_stage(self):
        hashes, outcomes, episode = self._run(actions_seed=1)
        episode.close()
        assert outcomes, "no step was taken"
        for out in outcomes:
            assert out.action is None or out.action.ok or out.action.reason
            assert not out.episode_over or out.end_reason, "an ended episode needs a reason"
            assert out.end_reason is None or out.end_reason in set(EndReason), (
                f"end_reason {out.end_reason!r} is not one of schemas.EndReason: "
                f"{[r.value for r in EndReason]}")

    def test_state_hash_is_deterministic(self):
        first, _, a = self._run(actions_seed=2)
        a.close()
        second, _, b = self._run(actions_seed=2)
        b.close()
        assert first == second, "same seed and actions gave different simulator states"

    def test_refused_and_empty_requests_do_not_raise(self):
        episode = self.plugin.make_episode(self._scenario())
        try:
            episode.reset()
            stage = self.plugin.stages()[0].name
            episode.on_stage_start(stage)
            for out in (episode.step(stage, {}), episode.answer(stage, {})):
                assert isinstance(out, StepOutcome)
                check_observation(episode.observation_spec, out.observation, "empty request")
        finally:
            episode.close()

    # ------------------------------------------------------------------------ files
    def test_verify_files_with_no_files(self):
        parsed, checks = self._checks({})
        assert parsed == {}
        required = {n for n, r in self.plugin.files.items() if r.required}
        assert {c.name for c in checks if not c.ok} == required

    def test_verify_files_with_garbage(self):
        junk = {
            "garbage": b"\x00\xff\xfe garbage \x80" * 20,
            "wrong JSON": b'{"no such field": [1, 2, 3], "version": 7}',
            "a JSON list": b"[1, 2, 3]",
            "empty": b"",
        }
        rules = self.plugin.files
        for what, data in junk.items():
            files = {name: data for name in rules}
            files["unexpected.bin"] = data  # not collected, and no reason to raise
            _, checks = self._checks(files)
            # None is valid: an empty log holds no record (schemas.parse_episode_log).
            accepted = [c.name for c in checks if c.ok and c.name in rules]
            assert not accepted, f"{what}: {accepted} accepted"

    def test_verify_files_with_valid_examples(self):
        files = self._example_files()
        parsed, checks = self._checks(files)
        failed = {c.name: c.reason for c in checks if not c.ok}
        assert not failed, f"valid example files refused: {failed}"
        assert set(parsed) >= {n for n, r in self.plugin.files.items() if r.required}

    # ---------------------------------------------------------------------- scoring
    def _check_card(self, card: ScoreCard) -> None:
        plugin = self.plugin
        assert isinstance(card, ScoreCard) and card.track == plugin.name
        assert 0.0 <= card.total <= 1.0
        assert set(card.components) == set(card.weights), "components and weights differ"
        assert set(card.components) <= set(plugin.weights), (
            f"components {sorted(card.components)} not among weights {sorted(plugin.weights)}"
        )
        assert math.isclose(sum(card.weights.values()), 1.0, abs_tol=1e-6), card.weights
        assert all(0.0 <= v <= 1.0 for v in card.components.values()), card.components
        total = sum(card.weights[k] * card.components[k] for k in card.components)
        assert math.isclose(card.total, min(1.0, max(0.0, total)), abs_tol=1e-6)
        for name in set(plugin.weights) - set(card.components):
            assert card.notes, f"component {name!r} left out without a note saying why"

    def test_score_of_an_agent_that_never_started(self):
        card = self.plugin.score(self._scoring_input(started=False))
        self._check_card(card)
        assert card == self.plugin.score(self._scoring_input(started=False))

    def test_score_of_an_agent_that_did_nothing(self):
        card = self.plugin.score(self._scoring_input(started=True))
        self._check_card(card)
        assert card == self.plugin.score(self._scoring_input(started=True))

    # ------------------------------------------------------------------------ hooks
    def test_audit_checks_are_fresh_and_read_an_episode(self):
        checks = self.plugin.audit()
        if checks is None:
            return  # the replay and the log steps only
        assert isinstance(checks, EpisodeChecks), (
            f"audit() returned {type(checks).__name__}, not a plugins.EpisodeChecks")
        assert self.plugin.audit() is not checks, "audit() must make fresh checks per episode"
        findings = self._audited(checks)
        assert all(isinstance(f, Finding) for f in findings), findings
        again = self.plugin.audit()
        assert again is not None and self._audited(again) == findings, (
            "the same episode, different findings")

    def test_vocabulary_fits_the_protocol_page(self):
        words = _vocabulary(self.track)
        assert isinstance(words, str), f"vocabulary() returned {type(words).__name__}"
        assert "<!--" not in words, "an HTML comment in the vocabulary breaks the page's sections"
