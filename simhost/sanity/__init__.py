"""The sanity arena (``eagc/Sanity-v0``): a point robot must find and reach a target."""

from __future__ import annotations

import gymnasium as gym

from simhost.sanity._arena import (
    HALF,
    REACH_RADIUS,
    SENSE_RADIUS,
    SanityArenaEnv,
    sample_point,
)

ENV_ID = "eagc/Sanity-v0"


def register_envs() -> None:
    """Registers ``eagc/Sanity-v0`` with gymnasium (idempotent)."""
    if ENV_ID not in gym.registry:
        gym.register(id=ENV_ID, entry_point="simhost.sanity._arena:SanityArenaEnv",
                     max_episode_steps=600)


register_envs()

__all__ = ["ENV_ID", "HALF", "REACH_RADIUS", "SENSE_RADIUS", "SanityArenaEnv", "register_envs",
           "sample_point"]
