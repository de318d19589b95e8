#!/usr/bin/env python
"""Fit the imitation policy's weights (``policy.npz``) on expert rollouts from the benches.

    python examples/track2_imitation/train.py [--pairs 40] [--split standard] [--seed 0]

For every family, ``--pairs`` times: draw a source instance and a hidden instance around it
(the split's variation), record the scripted expert's demonstration on the source and its
rollout on the instance (both through the split's observation channel, via the registered
gymnasium benches), run the policy's phase pointer along the rollout, and collect
``(s(o_t) - s(d_k), 1) -> a_t - a_demo(k)``. A ridge regression per family gives ``W``.
Host side only (it needs MuJoCo); CPU, about 5 minutes on two cores for 40 pairs.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from policy import DIM, LOOKAHEAD, features, state  # noqa: E402


def rollout(env, expert_cls, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The expert's observations (states) and actions on ``env`` reset with ``seed``."""
    obs, _ = env.reset(seed=seed)
    expert = expert_cls(env.unwrapped)
    states, actions = [state(obs["proprio"], obs["parts"])], []
    while True:
        a = expert()
        obs, _, term, trunc, _ = env.step(a)
        actions.append(a)
        states.append(state(obs["proprio"], obs["parts"]))
        if term or trunc:
            break
    return np.asarray(states), np.asarray(actions)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=40)
    ap.add_argument("--split", default="standard")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--ridge", type=float, default=1.0)
    ap.add_argument("--out", type=Path, default=HERE / "policy.npz")
    args = ap.parse_args()

    import gymnasium as gym

    from simhost.track2 import (
        FAMILIES,
        ScriptedExpert,
        env_id,
        register_envs,
        sample_instance,
        split_config,
    )

    register_envs()  # idempotent (``import simhost`` registers them too)

    variation = split_config(args.split).variation
    canon = variation.model_copy(update={"goal_from_source": False,
                                         "difficulty": variation.source_spread})
    weights = {}
    t0 = time.monotonic()
    for fam in FAMILIES:
        xs, ys = [], []
        for k in range(args.pairs):
            seed = args.seed * 100_000 + 1000 * FAMILIES.index(fam) + k
            source = sample_instance(fam, seed, variation=canon)
            hidden = sample_instance(fam, seed + 500, source=source, variation=variation)
            demo_env = gym.make(env_id(fam), params=source, split=args.split)
            d_states, d_actions = rollout(demo_env, ScriptedExpert, seed)
            demo_env.close()
            env = gym.make(env_id(fam), params=hidden, split=args.split)
            states, actions = rollout(env, ScriptedExpert, seed + 1)
            env.close()
            ptr, last = 0, len(d_actions) - 1
            for s, a in zip(states[:-1], actions, strict=True):
                window = d_states[ptr: min(ptr + LOOKAHEAD, last) + 1]
                ptr = min(last, ptr + int(np.argmin(np.linalg.norm(window - s, axis=1))))
                xs.append(features(s, d_states[ptr]))
                ys.append(a - d_actions[ptr])
                ptr = min(last, ptr + 1)
        x, y = np.asarray(xs), np.asarray(ys)
        w = np.linalg.solve(x.T @ x + args.ridge * np.eye(DIM + 1), x.T @ y)
        resid = float(np.mean((x @ w - y) ** 2))
        weights[fam] = w.astype(np.float32)
        print(f"{fam:10s} {len(x):6d} samples, residual {resid:.4f} "
              f"(vs {float(np.mean(y ** 2)):.4f} without correction), "
              f"{time.monotonic() - t0:.0f} s", flush=True)
    np.savez_compressed(args.out, **weights)
    print(f"wrote {args.out} ({args.out.stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
