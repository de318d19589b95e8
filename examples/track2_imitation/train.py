#!/usr/bin/env python
"""Fit the imitation policy (``policy.npz``) on expert rollouts from the gymnasium benches.

    python examples/track2_imitation/train.py [--pairs 80] [--split standard] [--seed 0]

For every family, ``--pairs`` times: draw a source instance and a hidden instance around it
(the split's variation), and record the scripted expert on both through the split's
observation channel (the registered gymnasium benches, ``eagc/Bench-<Family>-v0``). Steps
of the two runs are matched by key stage and the fraction of it done. Then, per family:

- attention: for each phase (half of a key stage, ``policy.phases``), the part in whose
  frame (frozen at the last grasp, as ``policy.py`` reads it) the expert's hand targets
  agree best between the two runs (the motion is relative to it), among the parts that do
  not travel during that phase (a part the hand carries says where it was, not where it
  goes; a knob turning in place counts); or the same in a *live* frame (the part as it is
  now) among the parts that neither travel nor turn (following a part the hand turns would
  cancel the turn);
- correction: a ridge regression from ``s(o) - s(d)`` to what the expert did beyond what
  following the attended part's moved target would do.

Host side only (it needs MuJoCo); CPU, about 3 minutes on two cores for 80 pairs.
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
    LIVE,
    NEXT,
    SCALE,
    absolute,
    anchor_of,
    attended_row,
    features,
    grasped_rows,
    part_pose,
    phases,
    relative,
    state,
    targets,
    wrap,
    yaw_of,
)


def rollout(env, expert_cls, seed: int) -> dict[str, np.ndarray | list[str]]:
    """The expert's observations, actions and true stages on ``env`` reset with ``seed``."""
    obs, info = env.reset(seed=seed)
    expert = expert_cls(env.unwrapped)
    prop, parts, acts, stages = [obs["proprio"]], [obs["parts"]], [], [info["stage"]]
    grasps: list[int] = []
    while True:
        a = expert()
        obs, _, term, trunc, info = env.step(a)
        acts.append(a)
        grasps += [len(acts)] * sum(e["event"] == "grasped" for e in info["events"])
        prop.append(obs["proprio"])
        parts.append(obs["parts"])
        stages.append(info["stage"])
        if term or trunc:
            break
    return {"proprio": np.asarray(prop, float), "parts": np.asarray(parts, float),
            "actions": np.asarray(acts, float), "stages": stages, "grasps": grasps,
            "phases": phases(stages[:-1])}


def align(demo: dict, run: dict) -> list[tuple[int, int, str]]:
    """``(run step, demo step, demo step's phase)`` matched by stage and the fraction done
    in it."""
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
            m = d[s][round(f * (len(d[s]) - 1))]  # the demonstration's step
            pairs.append((k, m, demo["phases"][m]))
    return pairs


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=80)
    ap.add_argument("--split", default="standard")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--ridge", type=float, default=10.0)
    ap.add_argument("--out", type=Path, default=HERE / "policy.npz")
    args = ap.parse_args()

    import gymnasium as gym

    from simhost.worlds.track2 import (
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
        err: dict[str, np.ndarray] = defaultdict(lambda: np.zeros(2 * LIVE))
        cnt: dict[str, int] = defaultdict(int)
        for demo, run in runs:
            td, tr = targets(demo["proprio"], demo["actions"]), targets(run["proprio"],
                                                                          run["actions"])
            moved: dict[str, np.ndarray] = {}  # travelled during the stage
            turned: dict[str, np.ndarray] = {}  # travelled or turned (no live frame then)
            for kind in set(demo["phases"]):
                idx = [i for i, x in enumerate(demo["phases"]) if x == kind]
                moved[kind] = np.ptp(demo["parts"][idx, :, 1:4], axis=0).max(axis=1) > 0.02
                yaws = np.array([[yaw_of(q) for q in demo["parts"][i, :, 4:8]] for i in idx])
                turned[kind] = moved[kind] | (np.abs(np.unwrap(yaws, axis=0)
                                                     - yaws[:1]).max(axis=0) > 0.3)
            taken_d = grasped_rows(demo["parts"], demo["grasps"])
            taken_r = grasped_rows(run["parts"], run["grasps"])
            for k, j, kind in align(demo, run):
                base_c = [*range(min(NEXT, run["parts"].shape[1])), NEXT]
                for att in [*base_c, *(LIVE + c for c in base_c)]:
                    rr = attended_row(att, run["parts"], run["grasps"], taken_r, k)
                    rd = attended_row(att, demo["parts"], demo["grasps"], taken_d, j)
                    if att >= LIVE:  # the part's frame now (observation after the action)
                        ak, aj = k + 1, j + 1
                    else:
                        ak, aj = anchor_of(run["grasps"], k), anchor_of(demo["grasps"], j)
                    gone = (turned if att >= LIVE else moved).get(kind, np.zeros(NEXT, bool))
                    if (run["parts"][ak, rr, 0] < 0.5 or demo["parts"][aj, rd, 0] < 0.5
                            or gone[rd]):
                        err[kind][att] += 1.0
                        continue
                    a = relative(tr[k], part_pose(run["parts"][ak, rr]))
                    b = relative(td[j], part_pose(demo["parts"][aj, rd]))
                    err[kind][att] += float(np.linalg.norm(a[:3] - b[:3]))
                cnt[kind] += 1
        rows = runs[0][1]["parts"].shape[1]
        valid = [*range(rows), NEXT, *(LIVE + c for c in (*range(rows), NEXT))]
        attend = {kind: int(valid[int(np.argmin(e[valid]))]) for kind, e in err.items()}
        attention[fam] = attend
        # correction: expert action minus the attended-target servo
        xs, ys = [], []
        for demo, run in runs:
            td = targets(demo["proprio"], demo["actions"])
            tr = targets(run["proprio"], run["actions"])
            taken_d = grasped_rows(demo["parts"], demo["grasps"])
            for k, j, kind in align(demo, run):
                att = attend.get(kind, 0)
                if att >= LIVE:
                    ak, aj = k + 1, j + 1
                else:
                    ak, aj = anchor_of(run["grasps"], k), anchor_of(demo["grasps"], j)
                # the policy attends the demonstration's row, in both runs
                row = attended_row(att, demo["parts"], demo["grasps"], taken_d, j)
                if run["parts"][ak, row, 0] < 0.5 or demo["parts"][aj, row, 0] < 0.5:
                    continue
                goal = absolute(relative(td[j], part_pose(demo["parts"][aj, row])),
                                part_pose(run["parts"][ak, row]))
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
