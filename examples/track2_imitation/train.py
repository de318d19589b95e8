#!/usr/bin/env python
"""Fit the imitation policy (``policy.npz``) on expert rollouts from the gymnasium benches.

    python examples/track2_imitation/train.py [--pairs 40] [--split standard] [--seed 0]

For every family, ``--pairs`` times: draw a source instance and a hidden instance around it
(the split's variation), and record the scripted expert on both through the split's
observation channel (the registered gymnasium benches, ``eagc/Bench-<Family>-v0``). Steps
of the two runs are matched by key stage and the fraction of it done. Then, per family:

- attention: for each kind of key stage, the part in whose frame the expert's hand targets
  agree best between the two runs (the motion is relative to it), among the parts that stay
  put during that stage (a part the hand carries agrees trivially and says nothing);
- correction: a ridge regression from ``s(o) - s(d)`` to what the expert did beyond what
  following the attended part's moved target would do.

Host side only (it needs MuJoCo); CPU, about 3 minutes on two cores for 40 pairs.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from policy import (  # noqa: E402
    DIM,
    DYAW,
    SCALE,
    absolute,
    features,
    part_pose,
    relative,
    stage_kind,
    state,
    targets,
    wrap,
)


def rollout(env, expert_cls, seed: int) -> dict[str, np.ndarray | list[str]]:
    """The expert's observations, actions and true stages on ``env`` reset with ``seed``."""
    obs, info = env.reset(seed=seed)
    expert = expert_cls(env.unwrapped)
    prop, parts, acts, stages = [obs["proprio"]], [obs["parts"]], [], [info["stage"]]
    while True:
        a = expert()
        obs, _, term, trunc, info = env.step(a)
        acts.append(a)
        prop.append(obs["proprio"])
        parts.append(obs["parts"])
        stages.append(info["stage"])
        if term or trunc:
            break
    return {"proprio": np.asarray(prop, float), "parts": np.asarray(parts, float),
            "actions": np.asarray(acts, float), "stages": stages}


def align(demo: dict, run: dict) -> list[tuple[int, int, str]]:
    """``(run step, demo step, stage kind)`` matched by stage and the fraction done in it."""
    def spans(stages: list[str]) -> dict[str, list[int]]:
        out: dict[str, list[int]] = defaultdict(list)
        for k, s in enumerate(stages[:-1]):
            out[s].append(k)
        return out

    d, r = spans(demo["stages"]), spans(run["stages"])
    pairs = []
    for s, ks in r.items():
        if s not in d:
            continue
        for j, k in enumerate(ks):
            f = j / max(1, len(ks) - 1)
            pairs.append((k, d[s][round(f * (len(d[s]) - 1))], stage_kind(s)))
    return pairs


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=40)
    ap.add_argument("--split", default="standard")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--ridge", type=float, default=10.0)
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
    out: dict[str, np.ndarray] = {}
    attention: dict[str, dict[str, int]] = {}
    t0 = time.monotonic()
    for fam in FAMILIES:
        runs = []
        for k in range(args.pairs):
            seed = args.seed * 100_000 + 1000 * FAMILIES.index(fam) + k
            source = sample_instance(fam, seed, variation=canon)
            hidden = sample_instance(fam, seed + 500, source=source, variation=variation)
            pair = []
            for params, reset in ((source, seed), (hidden, seed + 1)):
                env = gym.make(env_id(fam), params=params, split=args.split, render_rgbd=False)
                pair.append(rollout(env, ScriptedExpert, reset))
                env.close()
            runs.append(pair)
        # attention: per stage kind, the part whose frame makes the two runs' targets agree
        err: dict[str, np.ndarray] = defaultdict(lambda: np.zeros(6))
        cnt: dict[str, int] = defaultdict(int)
        for demo, run in runs:
            td, tr = targets(demo["proprio"], demo["actions"]), targets(run["proprio"],
                                                                          run["actions"])
            moved: dict[str, np.ndarray] = {}
            for kind in {stage_kind(x) for x in demo["stages"][:-1]}:
                idx = [i for i, x in enumerate(demo["stages"][:-1]) if stage_kind(x) == kind]
                pos = demo["parts"][idx, :, 1:4]
                moved[kind] = np.ptp(pos, axis=0).max(axis=1) > 0.02
            for k, j, kind in align(demo, run):
                for row in range(min(6, run["parts"].shape[1])):
                    if (run["parts"][k, row, 0] < 0.5 or demo["parts"][j, row, 0] < 0.5
                            or moved.get(kind, np.zeros(6, bool))[row]):
                        err[kind][row] += 1.0
                        continue
                    a = relative(tr[k], part_pose(run["parts"][k, row]))
                    b = relative(td[j], part_pose(demo["parts"][j, row]))
                    err[kind][row] += float(np.linalg.norm(a[:3] - b[:3]))
                cnt[kind] += 1
        rows = runs[0][1]["parts"].shape[1]
        attend = {kind: int(np.argmin(e[:rows])) for kind, e in err.items()}
        attention[fam] = attend
        # correction: expert action minus the attended-target servo
        xs, ys = [], []
        for demo, run in runs:
            td = targets(demo["proprio"], demo["actions"])
            tr = targets(run["proprio"], run["actions"])
            for k, j, kind in align(demo, run):
                row = attend.get(kind, 0)
                if run["parts"][k, row, 0] < 0.5 or demo["parts"][j, row, 0] < 0.5:
                    continue
                goal = absolute(relative(td[j], part_pose(demo["parts"][j, row])),
                                part_pose(run["parts"][k, row]))
                now = tr[k - 1] if k else run["proprio"][0, :4]
                step = np.clip(goal - now, -SCALE, SCALE)
                step[3] = float(np.clip(wrap(goal[3] - now[3]), -DYAW, DYAW))
                base = np.append(step / SCALE, demo["actions"][j, 4])
                xs.append(features(state(run["proprio"][k], run["parts"][k]),
                                   state(demo["proprio"][j], demo["parts"][j])))
                ys.append(run["actions"][k] - base)
        x, y = np.asarray(xs), np.asarray(ys)
        w = np.linalg.solve(x.T @ x + args.ridge * np.eye(DIM + 1), x.T @ y)
        out[fam] = w.astype(np.float32)
        print(f"{fam:10s} attention {attend}; {len(x)} samples, residual "
              f"{float(np.mean((x @ w - y) ** 2)):.4f} (vs {float(np.mean(y ** 2)):.4f}); "
              f"{time.monotonic() - t0:.0f} s", flush=True)
    out["attention"] = np.frombuffer(json.dumps(attention).encode(), dtype=np.uint8)
    np.savez_compressed(args.out, **out)
    print(f"wrote {args.out} ({args.out.stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
