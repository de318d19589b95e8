#!/usr/bin/env python
"""Track 2 step benchmark (issue 5): ``BenchEnv.step`` against raw ``mujoco.mj_step``.

    python tests/benchmarks/bench_track2.py [--quick] [--no-rgbd] [--families a,b]

For each of the five task families, one fixed instance (the family's canonical source,
``default_source``), in the same run and on the same model and data:

- ours: ``BenchEnv.step`` replaying the scripted expert's episode. The expert is run once
  first and its actions recorded, then every timed episode is ``reset`` (not timed) followed
  by ``env.step`` alone on the recorded actions, one clock reading around each call, so the
  expert's cost is not counted. The final state hash of every replay is checked against the
  expert's run (the replay must follow the same trajectory).
- raw: ``mujoco.mj_step`` of the env's own ``model``/``data``, ``SUBSTEPS`` calls per control
  step (one control step's worth of physics), timed together. Before each one the physics
  state the env had at the start of that control step (recorded during the expert's run) is
  restored with ``mj_setState`` (not timed) and ``ctrl`` is set to the control step's final
  value, so the raw steps meet the same contacts as ours.

The ratio (ours / raw, medians per control step) is what our controller (the ramped control
target, state backup and divergence check), the contact summary, the task's evaluation and
the observation add on top of the physics. Families run in interleaved rounds, so load
elsewhere on the machine spreads over all of them. Optionally one family again with
``render_rgbd=True`` (``MUJOCO_GL=egl`` unless already set), beside a raw ``mujoco.Renderer``
rendering the same RGB and depth images of both cameras.

Not collected by pytest (the file is ``bench_*.py``).
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from _machine import load_average, machine_line  # noqa: E402  (sibling)

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

RGBD_FAMILY = "insertion"


@dataclass
class Case:
    """One row: a family's env, its recorded episode and the samples gathered so far."""

    label: str
    env: Any
    actions: list[Any]
    states: list[Any]  # physics state at the start of each control step
    ctrls: list[Any]  # ctrl at the end of each control step
    final_hash: str
    success: bool
    ours_ns: list[int] = field(default_factory=list)
    raw_ns: list[int] = field(default_factory=list)
    render_ns: list[int] = field(default_factory=list)
    mismatches: int = 0
    episodes: int = 0


def _record(label: str, env: Any) -> Case:
    """Run the scripted expert once; keep its actions and the states along the way."""
    import mujoco
    import numpy as np

    from simhost.worlds.track2 import ScriptedExpert

    sig = mujoco.mjtState.mjSTATE_INTEGRATION
    m, d = env.model, env.data
    size = mujoco.mj_stateSize(m, sig)
    env.reset()
    expert = ScriptedExpert(env)
    actions, states, ctrls = [], [], []
    success = False
    while True:
        try:
            a = expert()
        except StopIteration:
            break
        st = np.empty(size)
        mujoco.mj_getState(m, d, st, sig)
        _, _, terminated, truncated, info = env.step(a)
        actions.append(a)
        states.append(st)
        ctrls.append(d.ctrl.copy())
        success = bool(info["success"])
        if terminated or truncated:
            break
    if not actions:
        raise RuntimeError(f"{label}: the expert gave no action")
    return Case(label, env, actions, states, ctrls, env.state_hash(), success)


def _time_ours(case: Case) -> None:
    """One timed replay: reset (untimed), then ``env.step`` alone per recorded action."""
    env, actions = case.env, case.actions
    env.reset()
    gc.collect()
    clock = time.perf_counter_ns
    step = env.step
    out = [0] * len(actions)
    for i, a in enumerate(actions):
        t0 = clock()
        step(a)
        out[i] = clock() - t0
    case.ours_ns.extend(out)
    case.episodes += 1
    if env.state_hash() != case.final_hash:
        case.mismatches += 1


def _time_raw(case: Case, substeps: int) -> None:
    """``substeps`` raw ``mj_step`` calls per control step, from the recorded states."""
    import mujoco

    sig = mujoco.mjtState.mjSTATE_INTEGRATION
    m, d = case.env.model, case.env.data
    set_state, mj_step = mujoco.mj_setState, mujoco.mj_step
    clock = time.perf_counter_ns
    gc.collect()
    out = [0] * len(case.states)
    for i, (st, ctrl) in enumerate(zip(case.states, case.ctrls, strict=True)):
        set_state(m, d, st, sig)
        d.ctrl[:] = ctrl
        t0 = clock()
        for _ in range(substeps):
            mj_step(m, d)
        out[i] = clock() - t0
    case.raw_ns.extend(out)


def _time_render(case: Case, n: int) -> None:
    """Raw ``mujoco.Renderer``: the same RGB then depth images the env's observation has,
    of every camera (``CAMERAS``)."""
    import mujoco

    from simhost.worlds.track2._bench import CAMERAS

    env = case.env
    h, w = env.image_size
    r = mujoco.Renderer(env.model, h, w)
    try:
        flags = r.scene.flags
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
        flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        sig = mujoco.mjtState.mjSTATE_INTEGRATION
        step = max(1, len(case.states) // n)
        clock = time.perf_counter_ns
        for st in case.states[::step][:n]:
            mujoco.mj_setState(env.model, env.data, st, sig)
            mujoco.mj_forward(env.model, env.data)
            t0 = clock()
            for camera in CAMERAS:
                r.update_scene(env.data, camera=camera)
                r.render()
                r.enable_depth_rendering()
                r.update_scene(env.data, camera=camera)
                r.render()
                r.disable_depth_rendering()
            case.render_ns.append(clock() - t0)
    finally:
        r.close()


def _q(s: list[int], p: float) -> float:
    """Quantile ``p`` of sorted nanoseconds, in ms."""
    return s[min(len(s) - 1, int(round(p * (len(s) - 1))))] / 1e6


def _machine() -> str:
    return machine_line("mujoco", "numpy", "gymnasium",
                        extra=f"MUJOCO_GL={os.environ.get('MUJOCO_GL')}")


def _table(cases: list[Case], substeps: int) -> list[str]:
    head = (
        f"{'family':<16} {'steps':>6} {'ctrl steps/s':>12} {'median ms':>9} {'p99 ms':>8} "
        f"{'raw ms/ctrl':>11} {'phys steps/s':>12} {'ratio':>6}"
    )
    lines = [head, "-" * len(head)]
    notes = []
    for c in cases:
        ours, raw = sorted(c.ours_ns), sorted(c.raw_ns)
        rate = 1e9 * len(ours) / sum(ours)
        phys = 1e9 * substeps * len(raw) / sum(raw)
        med, rmed = _q(ours, 0.5), _q(raw, 0.5)
        flag = "" if c.mismatches == 0 else " !"
        lines.append(
            f"{c.label:<16} {len(ours):>6} {rate:>12.0f} {med:>9.3f} {_q(ours, 0.99):>8.3f} "
            f"{rmed:>11.3f} {phys:>12.0f} {med / rmed:>5.2f}×{flag}"
        )
        if c.mismatches:
            notes.append(
                f"! {c.label}: {c.mismatches}/{c.episodes} replays ended in another state than "
                "the expert's run"
            )
        if not c.success:
            notes.append(f"note: {c.label}: the expert's episode did not succeed")
        if c.render_ns:
            r = sorted(c.render_ns)
            notes.append(
                f"{c.label}: raw mujoco.Renderer RGB + depth {c.env.image_size[1]}x"
                f"{c.env.image_size[0]}: {_q(r, 0.5):.3f} ms median, {_q(r, 0.99):.3f} ms p99 "
                f"(n={len(r)}); ours minus raw physics minus render "
                f"{_q(ours, 0.5) - rmed - _q(r, 0.5):.3f} ms"
            )
    lines.append("")
    lines += [
        "steps: control steps timed (the expert's episode × replays); ctrl steps/s: 1 / mean "
        "env.step",
        f"raw ms/ctrl: median time of the {substeps} mj_step calls of one control step; "
        "phys steps/s: 1 / mean mj_step",
        "ratio: median ms / raw ms/ctrl (controller, contact summary, evaluation and "
        "observation on top of the physics)",
    ]
    return [line.rstrip() for line in lines + notes]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer replays (< 20 s)")
    ap.add_argument("--families", default="", help="comma-separated families (default: all)")
    ap.add_argument("--no-rgbd", action="store_true", help=f"skip the {RGBD_FAMILY}+rgbd row")
    ap.add_argument(
        "--steps", type=int, default=None, help="control steps per family (default 2000, quick 400)"
    )
    ap.add_argument("--rounds", type=int, default=None, help="interleaved rounds (default 3)")
    args = ap.parse_args()

    from simhost.worlds.track2 import FAMILIES, BenchEnv, default_source
    from simhost.worlds.track2._bench import SUBSTEPS

    families = [f for f in FAMILIES if not args.families or f in args.families.split(",")]
    target = args.steps or (400 if args.quick else 2000)
    rgbd_target = max(20, target // 4)  # rendering makes a step ~5× dearer
    rounds = max(1, args.rounds or (1 if args.quick else 3))

    print(_machine())
    print(
        f"one instance per family (default_source); control step = {SUBSTEPS} physics substeps; "
        f"~{target} timed control steps per family over {rounds} interleaved round(s); "
        f"load average {load_average()}"
    )
    t_start = time.monotonic()
    cases: list[Case] = []
    failed: list[str] = []
    for fam in families:
        cases.append(_record(fam, BenchEnv(default_source(fam))))
    if not args.no_rgbd and RGBD_FAMILY in families:
        try:
            env = BenchEnv(default_source(RGBD_FAMILY), render_rgbd=True)
            cases.append(_record(f"{RGBD_FAMILY}+rgbd", env))
        except Exception as e:  # no GL: the table goes on without the row
            failed.append(f"{RGBD_FAMILY}+rgbd: skipped ({type(e).__name__}: {e})")
    for c in cases:
        print(
            f"  {c.label}: expert episode {len(c.actions)} control steps, success={c.success}",
            file=sys.stderr,
        )

    def reps(c: Case) -> int:
        want = rgbd_target if c.env.render_rgbd else target
        return max(1, math.ceil(want / len(c.actions)))

    for rnd in range(rounds):
        for c in cases:
            t0 = time.monotonic()
            per_round = math.ceil(reps(c) / rounds)
            for _ in range(per_round):
                _time_ours(c)
                _time_raw(c, SUBSTEPS)
            print(
                f"  round {rnd + 1}/{rounds} {c.label:<16} {per_round} replay(s) "
                f"({time.monotonic() - t0:.1f} s)",
                file=sys.stderr,
                flush=True,
            )
    for c in cases:
        if c.env.render_rgbd:
            _time_render(c, len(c.actions))
        c.env.close()

    print()
    print("\n".join(_table(cases, SUBSTEPS) + failed))
    print(f"\nload average at the end {load_average()}; total {time.monotonic() - t_start:.0f} s")
    return 0 if not failed and all(c.mismatches == 0 for c in cases) else 1


if __name__ == "__main__":
    sys.exit(main())
