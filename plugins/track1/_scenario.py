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
``simhost.worlds.track1.HouseParams``), ``env`` (sensing options: fields of
``simhost.worlds.track1.HouseEnvConfig``), ``render_rgbd`` and ``image_size``.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping, Sequence
from fractions import Fraction
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from plugins._errors import PluginError
from plugins.track1._budgets import execution_steps, exploration_steps
from plugins.track1._queries import plan_queries
from plugins.track1._tasks import make_task
from plugins.track1._types import EXCEPTION_TYPES, ExceptionType, Track1Scenario
from simhost.worlds.track1 import (
    ConfigError,
    HouseSplit,
    generate_house,
    house_split,
    initial_ground_truth,
)


class SplitParams(BaseModel):
    """A Track 1 split's scenario parameters, with their defaults (the split's own values
    are in ``Track1.splits``; a campaign file may override any)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    rooms: tuple[int, int] | None = None
    """Rooms per house (inclusive range); None: the split's own."""
    exception_probability: float = Field(0.5, ge=0.0, le=1.0)
    exceptions: tuple[ExceptionType, ...] = EXCEPTION_TYPES
    """The exception types allowed (Table III)."""
    goals: tuple[int, int] = (1, 1)
    """Clauses of the instruction (inclusive range within 1-3)."""
    language: Literal["templates", "grammar"] = "grammar"
    step_budgets: bool = True
    """False: no per-episode step budgets (the dev split)."""
    house_params: dict[str, Any] | None = None
    env: dict[str, Any] | None = None
    render_rgbd: bool | None = None
    image_size: tuple[int, int] | None = None

    @model_validator(mode="after")
    def _goals_in_range(self) -> SplitParams:
        lo, hi = self.goals
        if not 1 <= lo <= hi <= 3:
            raise ValueError(f"goals must satisfy 1 <= lo <= hi <= 3, got {[lo, hi]}")
        return self


KNOWN_PARAMS = tuple(SplitParams.model_fields)


def split_params(params: Mapping[str, Any]) -> SplitParams:
    """``params`` checked; PluginError naming an unknown or bad split parameter."""
    for key in params:
        if key not in KNOWN_PARAMS:
            near = difflib.get_close_matches(key, KNOWN_PARAMS, n=1)
            hint = f" Did you mean {near[0]!r}?" if near else ""
            raise PluginError(f"track1: unknown scenario parameter {key!r}.{hint} "
                              f"Known: {list(KNOWN_PARAMS)}")
    try:
        return SplitParams.model_validate(dict(params))
    except ValidationError as e:
        first = e.errors()[0]
        where = ".".join(str(x) for x in first["loc"]) or "params"
        raise PluginError(f"track1: bad scenario parameter {where}: {first['msg']}") from None


def check_params(params: Mapping[str, Any]) -> None:
    """Raises PluginError naming an unknown or bad split parameter."""
    split_params(params)


def split_config(split: str, params: Mapping[str, Any]) -> HouseSplit:
    """The split's houses and sensing with the campaign's overrides."""
    sp = split_params(params)
    house = dict(sp.house_params or {})
    if sp.rooms is not None:
        house["rooms"] = list(sp.rooms)
    env = dict(sp.env or {})
    if sp.render_rgbd is not None:
        env["render_rgbd"] = sp.render_rgbd
    if sp.image_size is not None:
        env["image_size"] = sp.image_size
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
    sp = split_params(params)
    config = split_config(split, params)
    layout = generate_house(seed, params=config.params)
    truth = initial_ground_truth(layout)
    rng = np.random.default_rng([seed, 1])
    allowed = [t for t in EXCEPTION_TYPES if t in sp.exceptions]
    probability = sp.exception_probability
    exception = None
    if allowed and rng.random() < probability:  # drawn even with an index: the seed's
        exception = allowed[int(rng.integers(len(allowed)))]  # later draws stay the same
    if index is not None:
        exception = stratified_exception(index, probability, allowed)
    lo, hi = sp.goals
    n_goals = int(rng.integers(lo, hi + 1))
    dev = sp.language == "templates"
    order = [exception, *(t for t in allowed if t != exception)] if exception else []
    try:
        task, planned = make_task(layout, truth, rng, dev=dev, n_goals=n_goals,
                                  exceptions=order)
    except LookupError as e:
        raise PluginError(f"track1: {e}; use another seed") from e
    spec = Track1Scenario(split=config, layout_digest=layout.digest(), rooms=len(layout.rooms),
                          task=task, exception=planned, queries=plan_queries(truth, rng))
    if not sp.step_budgets:
        return spec
    cfg = config.config
    budgets = {
        "exploration": exploration_steps(layout, truth, cfg.max_forward),
        "execution": execution_steps(layout, truth, spec, cfg.max_forward),
    }
    return spec.model_copy(update={"budgets": budgets})
