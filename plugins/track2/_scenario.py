"""Hidden Track 2 scenarios: a family, a demonstrated source and a hidden instance near it.

The split names a preset of ``simhost.worlds.track2.SPLITS`` (``dev``, ``standard``,
``challenge``; another split name must say ``preset``). From the episode seed
(``numpy.random.default_rng(seed)``) come four sub-seeds: the source (drawn around the
bench's canonical source, spread ``source_spread``), the hidden instance (around the source,
as the split's variation says), the demonstration's reset seed and the episode's reset seed
(attempt ``k`` resets with ``episode_seed + k``: its jitter and its observation noise).

The family is ``FAMILIES[index % 5]`` for the episode's index within its split in a
campaign (families balanced by index), ``FAMILIES[seed % 5]`` for a one-off episode, unless
the split names one.

Feasibility: the privileged expert must solve the source (the packet shows a success), and
the *feasibility expert* must solve the hidden instance. It is the scripted expert knowing
the instance's parameters (what a perfect task model would know) but perceiving only
through the observations the agent will get — noisy, delayed, occluded, biased — with
robust estimation (averaging while still, servoing on relative poses) and contact search;
like the agent it has ``max_attempts`` attempts, attempt ``k`` with the agent's reset seed
of attempt ``k`` (the same jitter and noise) and the episode's measurement biases, each
within the family's step cap. A draw it does not solve is redrawn with the next sub-seed,
at most ``MAX_DRAWS`` times; ``Track2Scenario.expert_steps`` / ``expert_attempt`` / ``draws``
record what it took. Keeping only draws solved at the first attempt would keep the easy
ones (the favourable noise and biases); any attempt counts, as it does for an agent.

Step budget: on a split with a ``budget_factor`` (the official ones), an attempt may take
``ceil(budget_factor * expert_steps)`` steps (at most the family's cap): a multiple of what a
system that knows the instance needs, so that probing every alternative does not fit.
Otherwise (``dev``) the family's cap; ``params.attempt_steps`` overrides both.

Split parameters (a campaign split's ``params``) are :class:`Track2SplitParams`; the hidden
scenario (organizer-only) is one typed model, :class:`Track2Scenario`.
"""

from __future__ import annotations

import difflib
import functools
import math
from collections.abc import Callable, Mapping
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, ValidationInfo, field_validator

from plugins._base import HiddenScenario
from plugins._errors import PluginError
from simhost.worlds.track2 import (
    FAMILIES,
    SPLITS,
    BenchConfig,
    InstanceParams,
    VariationConfig,
    family_step_cap,
    instance_distance,
    sample_instance,
)

MAX_ATTEMPTS = 3
MAX_DRAWS = 8


class Track2SplitParams(BaseModel):
    """A Track 2 split's scenario parameters (``split_params`` checks them, naming what is
    wrong)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    preset: str | None = None
    """The preset of ``simhost.worlds.track2.SPLITS`` (None: the split's own name)."""
    family: str | None = None
    """One family for every episode (None: balanced by index, or by seed)."""
    difficulty: float | None = None
    """Overrides the preset's variation difficulty, in [0, 1]."""
    source_spread: float | None = None
    """Overrides how far the source lies from the canonical one, in [0, 1]."""
    attempt_steps: int | None = None
    """The step cap of an attempt (None: from the feasibility expert, or the family's)."""
    max_attempts: int | None = None
    """Attempts allowed (None: ``MAX_ATTEMPTS``)."""
    demo_frames: bool | None = True
    """Images in the demonstration packet."""
    rgbd_only: bool | None = None
    """An observation of images without the parts rows."""
    image_size: tuple[int, int] | None = None
    """``[height, width]`` of the RGB-D images, each in [16, 1024] (None: the preset's,
    ``simhost.worlds.track2.OFFICIAL_IMAGE_SIZE`` on the official splits)."""

    @field_validator("family", mode="before")
    @classmethod
    def _known_family(cls, v: Any) -> Any:
        if v is not None and v not in FAMILIES:
            hint = difflib.get_close_matches(str(v), FAMILIES, n=1)
            did = f" Did you mean {hint[0]!r}?" if hint else ""
            raise ValueError(f"unknown family {v!r}.{did} Families: {list(FAMILIES)}")
        return v

    @field_validator("difficulty", "source_spread", mode="before")
    @classmethod
    def _unit_number(cls, v: Any, info: ValidationInfo) -> Any:
        if v is not None and not (isinstance(v, int | float) and not isinstance(v, bool)
                                  and math.isfinite(v) and 0.0 <= v <= 1.0):
            raise ValueError(f"{info.field_name} must be a number in [0, 1], got {v!r}")
        return v

    @field_validator("attempt_steps", "max_attempts", mode="before")
    @classmethod
    def _count(cls, v: Any, info: ValidationInfo) -> Any:
        hi = 100_000 if info.field_name == "attempt_steps" else MAX_ATTEMPTS
        if v is not None and not (isinstance(v, int) and not isinstance(v, bool)
                                  and 1 <= v <= hi):
            raise ValueError(f"{info.field_name} must be an integer in [1, {hi}], got {v!r}")
        return v

    @field_validator("image_size", mode="before")
    @classmethod
    def _size(cls, v: Any) -> Any:
        ok = (v is None or (isinstance(v, list | tuple) and len(v) == 2 and all(
            isinstance(x, int) and not isinstance(x, bool) and 16 <= x <= 1024 for x in v)))
        if not ok:
            raise ValueError(f"image_size must be [height, width], integers in [16, 1024], "
                             f"got {v!r}")
        return v

    @field_validator("demo_frames", "rgbd_only", mode="before")
    @classmethod
    def _flag(cls, v: Any, info: ValidationInfo) -> Any:
        if v is not None and not isinstance(v, bool):
            raise ValueError(f"{info.field_name} must be true or false, got {v!r}")
        return v


KNOWN_PARAMS = tuple(Track2SplitParams.model_fields)


class Track2Scenario(HiddenScenario):
    """Everything hidden about one Track 2 episode (``Scenario.params`` as JSON);
    ``Track2Scenario.of(scenario)`` reads one back from a ``Scenario``, the log's
    ``ScenarioRecord`` or its params."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    version: Literal["eagc-track2-scenario/v2"] = "eagc-track2-scenario/v2"
    preset: str = Field(description="The split preset: dev, standard or challenge.")
    family: str
    bench: BenchConfig
    variation: VariationConfig
    source: InstanceParams = Field(description="The demonstrated instance.")
    instance: InstanceParams = Field(description="The hidden instance the agent executes.")
    distance: float = Field(description="instance_distance(source, instance), in [0, 1].")
    demo_seed: int
    episode_seed: int = Field(description="Attempt k resets with episode_seed + k.")
    attempt_steps: int
    max_attempts: int
    demo_frames: bool = True
    expert_steps: int | None = Field(description="Steps the feasibility expert needed on the "
                                     "attempt it solved (None: no draw was solved).")
    expert_attempt: int | None = Field(None, description="The attempt the feasibility expert "
                                       "solved (1-based; None: none).")
    draws: int = Field(description="Instances drawn until one was feasible.")

    def reset_seed(self, attempt: int) -> int:
        """The reset seed of attempt ``attempt`` (1-based)."""
        return self.episode_seed + attempt


def family_of(seed: int, index: int | None, params: Track2SplitParams) -> str:
    """The episode's family: the split's, else by index within the split, else by seed."""
    if params.family is None:
        return FAMILIES[(seed if index is None else index) % len(FAMILIES)]
    return params.family


def split_params(split: str, params: Mapping[str, Any]) -> tuple[str, Track2SplitParams]:
    """The preset to use and the checked parameters; ``PluginError`` naming an unknown or
    ill-typed parameter."""
    for key in sorted(set(params) - set(KNOWN_PARAMS)):
        hint = difflib.get_close_matches(key, KNOWN_PARAMS, n=1)
        did = f" Did you mean {hint[0]!r}?" if hint else ""
        raise PluginError(f"track2: unknown scenario parameter {key!r}.{did} Known: "
                          f"{list(KNOWN_PARAMS)}")
    preset = str(params.get("preset", split))
    if preset not in SPLITS:
        hint = difflib.get_close_matches(preset, list(SPLITS), n=1)
        did = f" Did you mean {hint[0]!r}?" if hint else ""
        raise PluginError(f"track2: unknown split {preset!r}.{did} Splits: {list(SPLITS)} "
                          "(another split name must set params.preset)")
    try:
        return preset, Track2SplitParams.model_validate({**params, "preset": preset})
    except ValidationError as e:
        first = e.errors()[0]
        cause = first.get("ctx", {}).get("error")
        raise PluginError(f"track2: {cause or first['msg']}") from None


@functools.lru_cache(maxsize=512)
def expert_steps(instance_json: str, bench_json: str, seed: int, bias_seed: int | None,
                 cap: int, observed: bool, attempts: int = 1) -> tuple[int, int] | None:
    """``(steps, attempt)``: the steps the scripted expert needed on the first of up to
    ``attempts`` attempts it solved, attempt ``k`` reset with ``seed + k - 1`` (and the
    episode's ``bias_seed``); ``None`` if it solved none within ``cap`` steps each.
    ``observed``: it reads the observations, not the simulation."""
    from simhost.worlds.track2 import BenchEnv, ScriptedExpert

    bench = BenchConfig.model_validate_json(bench_json)
    if not bench.observation.parts:  # the observation expert reads the parts rows
        bench = bench.model_copy(update={"observation": bench.observation.model_copy(
            update={"parts": True})})
    env = BenchEnv(InstanceParams.model_validate_json(instance_json), config=bench,
                   render_rgbd=False, max_steps=cap)
    try:
        for attempt in range(1, attempts + 1):
            obs, _ = env.reset_typed(seed=seed + attempt - 1, options={"bias_seed": bias_seed})
            expert = ScriptedExpert(env, observed=observed, obs=obs)
            for k in range(1, cap + 1):
                obs, _, terminated, truncated, info = env.step_typed(expert(obs))
                if info.success:
                    return k, attempt
                if terminated or truncated:
                    break
        return None
    finally:
        env.close()


def _first_solved(draw: Callable[[int], tuple[InstanceParams, int]],
                  solved: Callable[[InstanceParams, int], tuple[int, int] | None]
                  ) -> tuple[InstanceParams, int, tuple[int, int] | None, int]:
    """The first draw ``draw(0)``, ``draw(1)``, … (an instance and its episode seed) that
    ``solved`` solves, else the last; with what ``solved`` said and the number of draws."""
    params, seed = draw(0)
    steps = None
    for k in range(1, MAX_DRAWS + 1):
        steps = solved(params, seed)
        if steps is not None:
            return params, seed, steps, k
        params, seed = draw(k)
    return params, seed, steps, MAX_DRAWS


def make_track2_scenario(seed: int, split: str, params: Mapping[str, Any],
                         index: int | None = None) -> Track2Scenario:
    """The hidden scenario of ``seed`` (``index`` within its split) in ``split``."""
    preset_name, sp = split_params(split, params)
    preset = SPLITS[preset_name]
    family = family_of(seed, index, sp)
    variation = preset.variation
    update = {k: float(v) for k, v in (("difficulty", sp.difficulty),
                                       ("source_spread", sp.source_spread)) if v is not None}
    if update:
        variation = variation.model_copy(update=update)
    bench = preset.bench
    if sp.image_size is not None:
        bench = bench.model_copy(update={"observation": bench.observation.model_copy(
            update={"image_size": tuple(sp.image_size)})})
    if sp.rgbd_only:
        bench = bench.model_copy(update={"observation": bench.observation.model_copy(
            update={"parts": False, "rgbd": True, "segmentation": True})})
    full = family_step_cap(family)
    max_attempts = sp.max_attempts or MAX_ATTEMPTS
    rng = np.random.default_rng(seed)
    src_seed, inst_seed, demo_seed, episode_seed = (
        int(x) for x in rng.integers(0, 2**31 - (MAX_DRAWS + 1) * (MAX_ATTEMPTS + 1), 4))
    bench_json = bench.model_dump_json()
    around_canon = variation.model_copy(update={"goal_from_source": False,
                                                "difficulty": variation.source_spread})
    source, demo_seed, _, _ = _first_solved(
        lambda k: (sample_instance(family, src_seed + k, variation=around_canon), demo_seed + k),
        lambda p, s: expert_steps(p.model_dump_json(), bench_json, s, None, full, False))
    # A redraw also redraws the episode's seed: its jitter, noise and measurement biases.
    stride = MAX_ATTEMPTS + 1
    instance, episode_seed, solved, draws = _first_solved(
        lambda k: (sample_instance(family, inst_seed + k, source=source, variation=variation),
                   episode_seed + stride * k),
        lambda p, s: expert_steps(p.model_dump_json(), bench_json, s + 1, s, full, True,
                                  max_attempts))
    steps, attempt = solved if solved is not None else (None, None)
    if sp.attempt_steps:
        cap = sp.attempt_steps
    elif preset.budget_factor is not None and steps is not None:
        cap = min(full, math.ceil(preset.budget_factor * steps))
    else:
        cap = full
    return Track2Scenario(
        preset=preset_name, family=family, bench=bench, variation=variation, source=source,
        instance=instance, distance=round(instance_distance(source, instance), 6),
        demo_seed=demo_seed, episode_seed=episode_seed, attempt_steps=cap,
        max_attempts=max_attempts, demo_frames=bool(sp.demo_frames),
        expert_steps=steps, expert_attempt=attempt, draws=draws)
