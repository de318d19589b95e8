"""Hidden Track 2 scenarios: a family, a demonstrated source and a hidden instance near it.

From the episode seed (``numpy.random.default_rng(seed)``): the family is
``FAMILIES[seed % 5]`` (families mix evenly over seeds) unless the split names one; then three
sub-seeds draw the source (around the bench's canonical source, spread ``source_spread``),
the hidden instance (around the source, spread ``difficulty``) and the demonstration's reset
seed. The scripted expert must solve both the source (the packet shows a success) and the
hidden instance (every instance is feasible within one attempt's step cap); a draw it fails
is redrawn with the next sub-seed, at most ``MAX_DRAWS`` times.

Scenario parameters (organizer-only; the agent sees the source's public part in the packet):
``family``, ``difficulty``, ``source`` and ``instance`` (full ``InstanceParams`` as JSON),
``distance`` (``instance_distance(source, instance)``), ``demo_seed``, ``attempt_steps``,
``max_attempts``, ``demo_frames``.
"""

from __future__ import annotations

import difflib
import functools
import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from plugins._registry import PluginError

if TYPE_CHECKING:
    from simhost.track2 import InstanceParams

MAX_ATTEMPTS = 3
SOURCE_SPREAD = 0.3
MAX_DRAWS = 8
DEFAULT_DIFFICULTY = 0.5
KNOWN_PARAMS = ("family", "difficulty", "source_spread", "attempt_steps", "max_attempts",
                "demo_frames")


def family_of(seed: int, params: Mapping[str, Any]) -> str:
    """The seed's family, or the one the split names."""
    from simhost.track2 import FAMILIES

    fam = params.get("family")
    if fam is None:
        return FAMILIES[seed % len(FAMILIES)]
    if fam not in FAMILIES:
        hint = difflib.get_close_matches(str(fam), FAMILIES, n=1)
        did = f" Did you mean {hint[0]!r}?" if hint else ""
        raise PluginError(f"track2: unknown family {fam!r}.{did} Families: {list(FAMILIES)}")
    return str(fam)


@functools.lru_cache(maxsize=256)
def expert_steps(instance_json: str, cap: int) -> int | None:
    """Steps the scripted expert needs on an instance (``None``: not solved within ``cap``)."""
    from simhost.track2 import BenchEnv, InstanceParams, ScriptedExpert

    env = BenchEnv(InstanceParams.model_validate_json(instance_json), max_steps=cap)
    try:
        env.reset(seed=0)
        expert = ScriptedExpert(env)
        for k in range(1, cap + 1):
            _, _, terminated, truncated, info = env.step(expert())
            if info["success"]:
                return k
            if terminated or truncated:
                return None
        return None
    finally:
        env.close()


def _check(params: Mapping[str, Any]) -> None:
    for key in sorted(set(params) - set(KNOWN_PARAMS)):
        hint = difflib.get_close_matches(key, KNOWN_PARAMS, n=1)
        did = f" Did you mean {hint[0]!r}?" if hint else ""
        raise PluginError(f"track2: unknown scenario parameter {key!r}.{did} Known: "
                          f"{list(KNOWN_PARAMS)}")
    for key in ("difficulty", "source_spread"):
        v = params.get(key)
        if v is not None and not (isinstance(v, int | float) and math.isfinite(v)
                                  and 0.0 <= v <= 1.0):
            raise PluginError(f"track2: {key} must be a number in [0, 1], got {v!r}")
    for key, hi in (("attempt_steps", 100_000), ("max_attempts", MAX_ATTEMPTS)):
        v = params.get(key)
        if v is not None and not (isinstance(v, int) and 1 <= v <= hi):
            raise PluginError(f"track2: {key} must be an integer in [1, {hi}], got {v!r}")


def _first_solved(draw: Callable[[int], InstanceParams], cap: int) -> InstanceParams:
    """The first of ``draw(0)``, ``draw(1)``, … the expert solves (else the last drawn)."""
    params = draw(0)
    for k in range(1, MAX_DRAWS + 1):
        if expert_steps(params.model_dump_json(), cap) is not None:
            break
        params = draw(k)
    return params


def scenario_params(seed: int, params: Mapping[str, Any]) -> dict[str, Any]:
    """The hidden parameters of ``seed`` given the split's (and campaign's) parameters."""
    from simhost.track2 import instance_distance, sample_instance
    from simhost.track2._families import TASKS

    _check(params)
    family = family_of(seed, params)
    difficulty = float(params.get("difficulty", DEFAULT_DIFFICULTY))
    spread = float(params.get("source_spread", SOURCE_SPREAD))
    cap = int(params.get("attempt_steps") or TASKS[family].max_steps)
    rng = np.random.default_rng(seed)
    src_seed, inst_seed, demo_seed = (int(x) for x in rng.integers(0, 2**31 - MAX_DRAWS, 3))
    # The demonstration must show a success: the expert gets the family's full step cap.
    full = TASKS[family].max_steps
    source = _first_solved(
        lambda k: sample_instance(family, src_seed + k, difficulty=spread), full)
    instance = _first_solved(
        lambda k: sample_instance(family, inst_seed + k, source=source, difficulty=difficulty),
        cap)
    return {
        "family": family,
        "difficulty": difficulty,
        "source": source.model_dump(mode="json"),
        "instance": instance.model_dump(mode="json"),
        "distance": round(instance_distance(source, instance), 6),
        "demo_seed": demo_seed,
        "attempt_steps": cap,
        "max_attempts": int(params.get("max_attempts", MAX_ATTEMPTS)),
        "demo_frames": bool(params.get("demo_frames", True)),
    }
