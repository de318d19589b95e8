"""Scripted experts: one per family, reading privileged state, one action per call.

Each family's plan (``FamilyTask.plan``) is a generator: approach, grasp, carry, align,
insert / turn / slide / press / pull, release — closing the loop on the exact part poses and
the hand's control target. It is what writes the demonstration packets.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from ._env import BenchEnv


class ScriptedExpert:
    """The family's scripted expert bound to the current episode of ``env``.

    Build it after ``env.reset()``; call it once per step for the next action. A new
    episode needs a new expert.
    """

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        base = env.unwrapped
        if not isinstance(base, BenchEnv):
            raise TypeError(f"ScriptedExpert drives a BenchEnv, got {type(base).__name__}")
        self.env = base
        self.episode = base.episode
        self._plan = base.task.plan(base)

    def __call__(self, obs: Any = None) -> np.ndarray:
        """The next action (``obs`` is ignored: the expert reads the simulation)."""
        return np.asarray(next(self._plan), dtype=np.float32)


def expert_policy(env: gym.Env[Any, Any]) -> np.ndarray:
    """The expert's next action for ``env``'s current episode.

    The expert is kept on the env and rebuilt when a new episode starts.
    """
    base = env.unwrapped
    expert = getattr(base, "_expert", None)
    if not isinstance(expert, ScriptedExpert) or expert.episode != getattr(base, "episode", -1):
        expert = ScriptedExpert(env)
        base._expert = expert  # type: ignore[attr-defined]
    return expert()
