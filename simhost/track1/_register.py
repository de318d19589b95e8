"""Gymnasium registration (no MuJoCo import: entry points are strings)."""

from __future__ import annotations

ENV_ID = "eagc/House-v0"
"""Standard split houses (3-5 rooms)."""
CHALLENGE_ENV_ID = "eagc/HouseChallenge-v0"
"""Challenge split houses (6-8 rooms)."""


def register_envs() -> None:
    """Register ``eagc/House-v0`` and ``eagc/HouseChallenge-v0`` (idempotent)."""
    from gymnasium.envs.registration import register, registry

    from ._layout import HouseParams

    if ENV_ID not in registry:
        register(id=ENV_ID, entry_point="simhost.track1._env:HouseEnv", max_episode_steps=1000)
    if CHALLENGE_ENV_ID not in registry:
        register(
            id=CHALLENGE_ENV_ID,
            entry_point="simhost.track1._env:HouseEnv",
            max_episode_steps=1500,
            kwargs={"params": HouseParams.challenge()},
        )
