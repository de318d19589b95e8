"""Gymnasium registration of the sanity arena (no MuJoCo import: the entry point is a string)."""

from __future__ import annotations

ENV_ID = "eagc/Sanity-v0"


def register_envs() -> list[str]:
    """Registers ``eagc/Sanity-v0`` with gymnasium; returns the ids (idempotent)."""
    from gymnasium.envs.registration import register, registry

    if ENV_ID not in registry:
        register(id=ENV_ID, entry_point="simhost.worlds.sanity._arena:SanityArenaEnv",
                 max_episode_steps=600)
    return [ENV_ID]
