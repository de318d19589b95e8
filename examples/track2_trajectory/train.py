#!/usr/bin/env python
"""Fit the trajectory baseline's world model (``dynamics.npz``) on the gymnasium benches.

    python examples/track2_trajectory/train.py [--instances 60] [--held-out 20]
        [--split standard] [--seed 0] [--ridge 1e-4] [--noise 0.25]

Data: for every family, ``--instances + --held-out`` instances drawn by the bench's public
instance generation (``sample_instance`` with the split's variation, seeds
``seed * 100000 + 1000 * family + k``: no campaign's seeds; an opening's mechanism taken
in turn, drawer, sliding cover, swivel lid, either hand), each played once by the
scripted expert through ``eagc/Bench-<Family>-v0`` with exploration: on a quarter of the
steps (``--noise``) the hand's motion gets Gaussian noise (0.5 of full scale), so the data
hold motions the expert would not make while it grasps. Each step of each present row the
hand can move (``worldmodel.MOVABLE``) gives one sample: the features of
``worldmodel.features`` (the hand's motion in the part's frame, held or not, the part's
offset from the hand) and the part's true motion in its own frame (the simulation's
state, not the noisy channel: the model learns the physics; the agent filters its
observations).

Fit: one ridge regression per kind of part (``worldmodel.KINDS``) on the first
``--instances`` of every family; the last ``--held-out`` are held out and the script
prints the prediction error there beside two floors: "parts do not move" and "a held part
moves rigidly with the hand". Host side (MuJoCo), CPU, about 2 minutes on two cores.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from worldmodel import (  # noqa: E402
    DIM,
    KINDS,
    MOVABLE,
    features,
    held_row,
    kind_of,
    rigid,
    rot2,
    wrap,
)

MECHANISMS = KINDS[2:]  # an opening's: drawer, sliding cover, swivel lid


def yaw_of(q: np.ndarray) -> float:
    w, x, y, z = (float(v) for v in q)
    return float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


def rollout(env: object, expert_cls: type, seed: int, noise: float,
            rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The hand's proprioception and the parts' true rows at every step of one run."""
    u = env.unwrapped  # type: ignore[attr-defined]
    obs, _ = env.reset(seed=seed)  # type: ignore[attr-defined]
    expert = expert_cls(u)
    prop, parts = [obs["proprio"]], [np.array(u.task.parts(), float)]
    while True:
        a = np.asarray(expert(), dtype=np.float32)
        if rng.random() < noise:
            a[:4] = np.clip(a[:4] + 0.5 * rng.standard_normal(4), -1, 1)
        obs, _, term, trunc, _ = env.step(a)  # type: ignore[attr-defined]
        prop.append(obs["proprio"])
        parts.append(np.array(u.task.parts(), float))
        if term or trunc:
            break
    return np.asarray(prop, float), np.asarray(parts, float)


def samples(family: str, mechanism: str, prop: np.ndarray, parts: np.ndarray
            ) -> dict[str, tuple[list[np.ndarray], list[np.ndarray]]]:
    """Per kind: (features, the part's motion in its own frame) of every step and row."""
    out: dict[str, tuple[list[np.ndarray], list[np.ndarray]]] = defaultdict(lambda: ([], []))
    for t in range(len(prop) - 1):
        d_hand = prop[t + 1, :4] - prop[t, :4]
        d_hand[3] = float(wrap(d_hand[3]))
        holds = held_row(prop[t], parts[t], MOVABLE[family])
        for i in MOVABLE[family]:
            if parts[t, i, 0] < 0.5 or parts[t + 1, i, 0] < 0.5:
                continue
            a, b = parts[t, i], parts[t + 1, i]
            yaw = yaw_of(a[4:8])
            f = features(d_hand, float(holds == i), a[1:3] - prop[t, :2], yaw)
            d = rot2(-yaw, b[1:3] - a[1:3])
            y = np.array([d[0], d[1], b[3] - a[3], float(wrap(yaw_of(b[4:8]) - yaw))])
            xs, ys = out[kind_of(family, i, mechanism)]
            xs.append(f)
            ys.append(y)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--instances", type=int, default=60)
    ap.add_argument("--held-out", type=int, default=20)
    ap.add_argument("--split", default="standard")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--ridge", type=float, default=1e-4)
    ap.add_argument("--noise", type=float, default=0.25)
    ap.add_argument("--out", type=Path, default=HERE / "dynamics.npz")
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

    register_envs()
    variation = split_config(args.split).variation
    rng = np.random.default_rng(args.seed)
    train: dict[str, tuple[list[np.ndarray], list[np.ndarray]]] = defaultdict(lambda: ([], []))
    test: dict[str, tuple[list[np.ndarray], list[np.ndarray]]] = defaultdict(lambda: ([], []))
    t0 = time.monotonic()
    for fam in FAMILIES:
        for k in range(args.instances + args.held_out):
            seed = args.seed * 100_000 + 1000 * FAMILIES.index(fam) + k
            params = sample_instance(fam, seed, variation=variation)
            if fam == "opening":  # every mechanism alike often (the split draws drawers
                # mostly around its canonical instance), either hand of it
                params = params.model_copy(update={"geometry": {
                    **params.geometry, "kind": MECHANISMS[k % 3],
                    "mirror": bool(rng.random() < 0.5)}})
            env = gym.make(env_id(fam), params=params, split=args.split, render_rgbd=False)
            prop, parts = rollout(env, ScriptedExpert, seed, args.noise, rng)
            env.close()
            mech = str(params.geometry.get("kind", ""))
            into = train if k < args.instances else test
            for kind, (xs, ys) in samples(fam, mech, prop, parts).items():
                into[kind][0].extend(xs)
                into[kind][1].extend(ys)
        print(f"{fam:10s} {time.monotonic() - t0:.0f} s", flush=True)
    weights: dict[str, np.ndarray] = {}
    print(f"{'kind':14s}{'train':>7s}{'test':>7s}  held-out RMS error, held steps "
          f"(mm, mm, mrad): model / rigid / still")
    for kind in KINDS:
        if kind not in train:
            continue
        x, y = np.asarray(train[kind][0]), np.asarray(train[kind][1])
        w = np.linalg.solve(x.T @ x + args.ridge * np.eye(DIM), x.T @ y)
        weights[kind] = w.astype(np.float32)
        xt, yt = np.asarray(test[kind][0]), np.asarray(test[kind][1])
        if len(xt) == 0 or not (xt[:, 6] > 0.5).any():
            print(f"{kind:14s}{len(x):7d}{len(xt):7d}  (no held-out held steps)")
            continue
        hold = xt[:, 6] > 0.5
        xh, yh = xt[hold], yt[hold]

        def rms(pred: np.ndarray, y: np.ndarray = yh) -> str:
            e = np.sqrt(np.mean((pred - y) ** 2, axis=0)) * 1000
            return f"{np.hypot(e[0], e[1]):.2f} {e[2]:.2f} {e[3]:.1f}"

        print(f"{kind:14s}{len(x):7d}{len(xt):7d}  {rms(xh @ w)} / "
              f"{rms(np.array([rigid(f) for f in xh]))} / {rms(np.zeros_like(yh))}"
              f"  ({int(hold.sum())} held)")
    np.savez_compressed(args.out, **weights)
    print(f"wrote {args.out} ({args.out.stat().st_size} bytes); "
          f"{time.monotonic() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
