"""An episode's own step caps (``TrackEpisode.step_budget``) reach the agent and end stages."""

from __future__ import annotations

import numpy as np

from simhost.client import RemoteEnv


def test_episode_step_budget_is_announced_and_enforced(sim_host):
    handle = sim_host(step_budgets={"explore": 3}, max_steps_per_stage=10)
    env = RemoteEnv(handle.endpoint, handle.episode, timeout_s=10.0)
    try:
        spec = env.hello(agent="test")
        caps = {s.name: s.max_steps for s in spec.stages}
        # The smaller of the episode's cap and the campaign-wide one, per stage.
        assert caps == {"explore": 3, "reach": 10}
        ts = env.reset()
        assert ts.stage == "explore" and ts.steps_left == 3
        for _ in range(3):
            ts = env.step({"velocity": np.zeros(2, np.float32)})
        assert ts.stage == "reach", "the episode's cap of 3 steps did not end the stage"
    finally:
        env.close()
    outcome = handle.outcome(timeout=10.0)
    assert outcome.stage_ends["explore"] == "steps"
