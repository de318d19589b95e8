"""Hidden Track 1 scenarios: a house, an ALFRED-like task, a planned exception and queries.

Everything comes from the episode seed and the split: the house is
``generate_house(seed, split.params)`` (the generator is public; the seed is what is
hidden), sensed as ``split.config`` says, and ``numpy.random.default_rng([seed, 1])``
draws, in order, whether there is an exception and which type (Table III), how many goals
the instruction has, the task (one the exception can matter to, ``_tasks``) and the
queries asked at the end of exploration (``_queries``).

In a campaign the episode's index within its split decides whether it has an exception
and which (``stratified_exception``), so that any block of consecutive indices holds the
split's mix (at ``exception_probability`` 0.5 and four types, every 8 consecutive
episodes hold one of each type and four without): a campaign's final no longer moves
with how many exceptions its seeds happened to draw. The seed still decides the house,
the task (made for that type where the house can hold it, else the next type that fits,
as for a drawn one) and where the exception strikes. A one-off episode (no index) keeps
the seeded draw.

Split parameters (``KNOWN_PARAMS``, the split's defaults in ``Track1.splits``):
``rooms`` (inclusive range), ``exception_probability``, ``exceptions`` (the allowed
types), ``goals`` (inclusive range of clauses), ``language`` (``templates``: the dev
split's six templates with the substitute rule stated; ``grammar``: the paraphrasing
grammar), ``step_budgets`` (false: no per-episode step budgets, as on the dev split),
``house_params`` (an organizer parameter pack: fields of
``simhost.track1.HouseParams``), ``env`` (sensing options: fields of
``simhost.track1.HouseEnvConfig``), ``render_rgbd`` and ``image_size``.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping, Sequence
from fractions import Fraction
from typing import Any

import numpy as np

from plugins._errors import PluginError
from plugins.track1._budgets import execution_steps, exploration_steps
from plugins.track1._queries import plan_queries
from plugins.track1._tasks import make_task
from plugins.track1._types import EXCEPTION_TYPES, Track1Scenario
from simhost.track1 import (
    ConfigError,
    HouseSplit,
    generate_house,
    house_split,
    initial_ground_truth,
)

KNOWN_PARAMS = ("rooms", "exception_probability", "exceptions", "goals", "language",
                "step_budgets", "house_params", "env", "render_rgbd", "image_size")


def check_params(params: Mapping[str, Any]) -> None:
    """Raises PluginError naming an unknown or bad split parameter."""
    for key in params:
        if key not in KNOWN_PARAMS:
            near = difflib.get_close_matches(key, KNOWN_PARAMS, n=1)
            hint = f" Did you mean {near[0]!r}?" if near else ""
            raise PluginError(f"track1: unknown scenario parameter {key!r}.{hint} "
                              f"Known: {list(KNOWN_PARAMS)}")
    bad = [t for t in params.get("exceptions", ()) if t not in EXCEPTION_TYPES]
    if bad:
        raise PluginError(f"track1: unknown exception types {bad}; known: {EXCEPTION_TYPES}")
    p = float(params.get("exception_probability", 0.5))
    if not 0.0 <= p <= 1.0:
        raise PluginError(f"track1: exception_probability must be in [0, 1], got {p}")
    lo, hi = params.get("goals", (1, 1))
    if not 1 <= int(lo) <= int(hi) <= 3:
        raise PluginError(f"track1: goals must satisfy 1 <= lo <= hi <= 3, got {[lo, hi]}")
    if params.get("language", "grammar") not in ("templates", "grammar"):
        raise PluginError(f"track1: language must be 'templates' or 'grammar', got "
                          f"{params['language']!r}")


def split_config(split: str, params: Mapping[str, Any]) -> HouseSplit:
    """The split's houses and sensing with the campaign's overrides."""
    house = dict(params.get("house_params") or {})
    if "rooms" in params:
        house["rooms"] = list(params["rooms"])
    env = dict(params.get("env") or {})
    for key in ("render_rgbd", "image_size"):
        if key in params:
            env[key] = params[key]
    try:
        return house_split(split).with_overrides(params=house, config=env)
    except (ConfigError, ValueError) as e:
        raise PluginError(f"track1: bad split parameters for {split!r}: {e}") from e


def stratified_exception(index: int, probability: float, allowed: Sequence[str]
                         ) -> str | None:
    """The exception type of the ``index``-th episode of a split (None: no exception).

    Slot ``i`` has an exception when ``floor((i + 1) p) > floor(i p)`` (exceptions spread
    evenly at rate ``p``), and the exception slots take the allowed types in turn, so every
    ``len(allowed) / p`` consecutive indices (for a rational ``p``) hold the exact mix."""
    if not allowed or index < 0:
        return None
    p = Fraction(probability).limit_denominator(1000)  # exact: no rounding moves a slot
    before = math.floor(index * p)  # exception slots before this one
    if math.floor((index + 1) * p) <= before:
        return None
    return allowed[before % len(allowed)]


def build_scenario(seed: int, split: str, params: Mapping[str, Any],
                   index: int | None = None) -> Track1Scenario:
    """The hidden scenario of a seed in a split (same arguments, same scenario); with the
    episode's ``index`` in its split, the exception type comes from the index."""
    check_params(params)
    config = split_config(split, params)
    layout = generate_house(seed, params=config.params)
    truth = initial_ground_truth(layout)
    rng = np.random.default_rng([seed, 1])
    allowed = [t for t in EXCEPTION_TYPES if t in params.get("exceptions", EXCEPTION_TYPES)]
    probability = float(params.get("exception_probability", 0.5))
    exception = None
    if allowed and rng.random() < probability:  # drawn even with an index: the seed's
        exception = allowed[int(rng.integers(len(allowed)))]  # later draws stay the same
    if index is not None:
        exception = stratified_exception(index, probability, allowed)
    lo, hi = params.get("goals", (1, 1))
    n_goals = int(rng.integers(int(lo), int(hi) + 1))
    dev = params.get("language", "grammar") == "templates"
    order = [exception, *(t for t in allowed if t != exception)] if exception else []
    try:
        task, planned = make_task(layout, truth, rng, dev=dev, n_goals=n_goals,
                                  exceptions=order)
    except LookupError as e:
        raise PluginError(f"track1: {e}; use another seed") from e
    spec = Track1Scenario(split=config, layout_digest=layout.digest(), rooms=len(layout.rooms),
                          task=task, exception=planned, queries=plan_queries(truth, rng))
    if not params.get("step_budgets", True):
        return spec
    cfg = config.config
    budgets = {
        "exploration": exploration_steps(layout, truth, cfg.max_forward),
        "execution": execution_steps(layout, truth, spec, cfg.max_forward),
    }
    return spec.model_copy(update={"budgets": budgets})
