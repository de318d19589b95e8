"""Gymnasium registration (no MuJoCo import: entry points are strings).

Each id is one split of ``SPLITS`` (its houses and its sensing), so that offline training
sees what the evaluation shows: ``eagc/HouseDev-v0`` (the public getting-started level),
``eagc/House-v0`` (standard), ``eagc/HouseChallenge-v0`` (challenge) and
``eagc/HouseVision-v0`` (vision: pixels in, actions by pixel).
"""

from __future__ import annotations

DEV_ENV_ID = "eagc/HouseDev-v0"
"""The dev split: 3-5 rooms, exact all-round perception."""
ENV_ID = "eagc/House-v0"
"""The standard split: 3-5 rooms, a robot's perception."""
CHALLENGE_ENV_ID = "eagc/HouseChallenge-v0"
"""The challenge split: 6-8 rooms, a robot's perception."""
VISION_ENV_ID = "eagc/HouseVision-v0"
"""The vision split: the standard houses and robot without a detector; actions by pixel."""

ENV_IDS = {"dev": DEV_ENV_ID, "standard": ENV_ID, "challenge": CHALLENGE_ENV_ID,
           "vision": VISION_ENV_ID}
_STEPS = {"dev": 1000, "standard": 1000, "challenge": 1500, "vision": 1000}


def register_envs() -> None:
    """Register the Track 1 ids, one per split (idempotent)."""
    from gymnasium.envs.registration import register, registry

    for split, env_id in ENV_IDS.items():
        if env_id not in registry:
            register(id=env_id, entry_point="simhost.worlds.track1._env:HouseEnv",
                     max_episode_steps=_STEPS[split], kwargs={"split": split})
