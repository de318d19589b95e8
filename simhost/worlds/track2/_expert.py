"""Scripted experts: one per family, knowing the instance's parameters, one action per call.

Each family's plan (``FamilyTask.plan``) is a generator: approach, grasp, carry, align,
insert / turn / slide / press / pull, release. It reads part poses through an eye:

- ``ScriptedExpert(env)`` — the privileged oracle: the simulation's exact state. It writes
  the demonstration packets and is the bound an agent is measured against.
- ``ScriptedExpert(env, observed=True, obs=first_obs)`` — the same plans through
  :class:`~simhost.worlds.track2._eye.ObservedEye`, i.e. through the noisy, delayed, occluded
  observation channel an agent gets; call it with every new observation. The feasibility
  check of the hidden instances runs this one.

Proprioception (the hand's pose, speed and control target) is exact either way.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from ._env import BenchEnv
from ._eye import ObservedEye


class ScriptedExpert:
    """The family's scripted expert bound to the current episode of ``env``.

    Build it after ``env.reset()``; call it once per step for the next action. A new
    episode needs a new expert.

    Args:
      env: the bench (or a wrapper of it).
      observed: read part poses from the observations instead of the simulation.
      obs: the observation ``reset`` returned (needed when ``observed``).
    """

    def __init__(self, env: gym.Env[Any, Any], *, observed: bool = False,
                 obs: dict[str, np.ndarray] | None = None) -> None:
        base = env.unwrapped
        if not isinstance(base, BenchEnv):
            raise TypeError(f"ScriptedExpert drives a BenchEnv, got {type(base).__name__}")
        self.env = base
        self.episode = base.episode
        self.observed = observed
        task = base.task
        task.eye = None
        if observed:
            if obs is None or "parts" not in obs:
                raise ValueError("an observed expert needs the reset observation with 'parts'")
            self.eye: ObservedEye | None = ObservedEye(
                task, base.config.observation, priors=task.yaw_priors(), links=task.row_links())
            self.eye.update(obs)
            self._last = obs
        else:
            self.eye = None
        self._plan = task.plan(base)

    def __call__(self, obs: Any = None) -> np.ndarray:
        """The next action. An observed expert takes the latest observation first (the
        privileged one ignores ``obs``)."""
        if self.eye is not None and obs is not None and obs is not self._last:
            self.eye.update(obs)
        self._last = obs
        self.env.task.eye = self.eye
        try:
            return np.asarray(next(self._plan), dtype=np.float32)
        finally:
            self.env.task.eye = None

    _last: Any = None


def expert_policy(env: gym.Env[Any, Any]) -> np.ndarray:
    """The privileged expert's next action for ``env``'s current episode.

    The expert is kept on the env and rebuilt when a new episode starts.
    """
    base = env.unwrapped
    expert = getattr(base, "_expert", None)
    if not isinstance(expert, ScriptedExpert) or expert.episode != getattr(base, "episode", -1):
        expert = ScriptedExpert(env)
        base._expert = expert  # type: ignore[attr-defined]
    return expert()
