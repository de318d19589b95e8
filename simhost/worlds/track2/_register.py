"""Gymnasium registration (no MuJoCo import: entry points are strings)."""

from __future__ import annotations

from ._params import FAMILIES


def env_id(family: str) -> str:
    """The gymnasium id of a family's bench, e.g. ``eagc/Bench-ToolUse-v0``."""
    return f"eagc/Bench-{family.title().replace('_', '')}-v0"


ENV_IDS: tuple[str, ...] = tuple(env_id(f) for f in FAMILIES)
"""One id per family, in ``FAMILIES`` order."""


def register_envs() -> list[str]:
    """Register ``eagc/Bench-<Family>-v0`` for every family; returns the ids (idempotent).

    Keyword arguments pass through ``gymnasium.make``: ``split="standard"`` (or
    ``"challenge"``) gives the official observation channel, bench and variation;
    ``instance_seed=N`` a sampled instance; the default is the ``dev`` split's canonical
    source.
    """
    from gymnasium.envs.registration import register, registry

    for fam, eid in zip(FAMILIES, ENV_IDS, strict=True):
        if eid not in registry:
            register(id=eid, entry_point="simhost.worlds.track2._env:BenchEnv",
                     kwargs={"family": fam})
    return list(ENV_IDS)
