#!/usr/bin/env python
"""Track 1 house benchmark (issue 4): ``HouseEnv.step`` against raw ``mujoco.mj_step``.

    python tests/benchmarks/bench_track1.py [--quick] [--rounds R] [--json out.json]

On fixed seeds of standard (3-5 rooms) and challenge (6-8 rooms) houses, in the same run:

- raw: ``mujoco.mj_step`` on the env's own ``model``/``data`` (after ``reset``), timed in
  blocks of as many physics steps as one uncollided ``move`` takes (turn + forward + settle
  steps of ``HouseEnvConfig``, 85 by default): the physics floor of one control step;
- env: ``HouseEnv.step`` without rendering, a fixed mix of primitives: 14/20 ``move`` (a
  seeded wander that keeps clear of walls: the heading within +-40 deg of ahead with the
  longest free run by the range scan, with jitter, as far as it is free; a pure 45 deg turn
  when nothing ahead is free; straight back after a collided move), 2/20 ``noop``, 2/20
  ``open`` of the nearest visible door or container that is not open, 2/20 ``pick`` of the
  nearest visible object or tool (open and pick are attempts: they fail when out of reach,
  at the cost of their checks);
- rgbd: the same steps with RGB-D + segmentation at 320x240 (``render_rgbd=True``,
  ``MUJOCO_GL=egl`` set before mujoco is imported).

Every configuration runs in a fresh process (per house kind and round), which reports its
latencies and its peak resident memory (``VmHWM`` of /proc/self/status; no tracemalloc) and
its RSS right after the imports, so memory figures never mix. The action sequence is seeded
and the physics deterministic, so env and rgbd replay the same trajectories. Rounds
interleave the configurations, so load elsewhere on the machine spreads over all of them.
Only the ``step`` call (or the block of ``mj_step`` calls) is timed; choosing targets,
``reset`` and the warm-up are not.

Not collected by pytest (the file is ``bench_*.py``).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from _machine import die_with_parent, load_average, machine_line, reap, run_child  # noqa: E402  (sibling)

ROOT = Path(__file__).resolve().parents[2]
KINDS = ("standard", "challenge")
SEEDS = (3, 7, 42)
IMAGE = (320, 240)
# simhost.worlds.track1._mjcf.ROBOT_RADIUS (wandering moves keep clear of walls)
ROBOT_RADIUS = 0.25
# one cycle of the primitive mix: m move, n noop, o open, p pick
MIX = "mmmnmmommpmmmnmmommp"
PRIM = {"m": "move", "n": "noop", "o": "open", "p": "pick"}

# name, label
CONFIGS: list[tuple[str, str]] = [
    ("raw", "raw mj_step x {k} (one move)"),
    ("env", "HouseEnv.step, no render"),
    ("rgbd", f"HouseEnv.step + RGB-D {IMAGE[0]}x{IMAGE[1]}"),
]
# per seed and round: (timed control steps or mj_step blocks, warm-up), full / quick
COUNTS = {
    "raw": ((120, 20), (60, 10)),
    "env": ((150, 15), (80, 8)),
    "rgbd": ((40, 4), (16, 3)),
}


# ================================================================================ children

def _status_kib(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    return -1


def _gl_renderer() -> str:
    """The OpenGL renderer string of the current (EGL) context, if it can be read."""
    with contextlib.suppress(Exception):
        from OpenGL import GL

        return GL.glGetString(GL.GL_RENDERER).decode()
    return "?"


def _free(scan: Any, heading: float) -> float:
    """How far the base can drive straight along ``heading`` (robot frame, radians) before
    its disc, with a margin, reaches a point of the range scan."""
    rays = len(scan)
    angles = [2 * math.pi * j / rays - heading for j in range(rays)]
    reach = ROBOT_RADIUS + 0.15
    free = 8.0
    for r, a in zip(scan, angles, strict=True):
        along, lateral = float(r) * math.cos(a), abs(float(r) * math.sin(a))
        if along > 0 and lateral < reach:
            free = min(free, along - math.sqrt(reach * reach - lateral * lateral))
    return free


def _move(rng: Any, scan: Any, backoff: bool) -> tuple[float, float]:
    """A wandering move: the heading within +-40 deg of ahead with the longest free run by
    the range scan (seeded jitter), as far as it is free; straight back after a collided
    move; a pure 45 deg turn towards the freer side when nothing ahead is free."""
    if backoff:
        back = _free(scan, math.pi)
        if back > 0.2:
            return -min(1.0, back / 0.5), 0.0
    headings = [math.radians(d) for d in range(-40, 41, 10)]
    _, heading = max((_free(scan, h) + float(rng.uniform(0.0, 0.5)), h) for h in headings)
    forward = min(1.0, max(0.0, (_free(scan, heading) - 0.1) / 0.5))
    if forward < 0.2:
        rays = len(scan)
        left = sum(float(scan[k]) for k in range(1, rays // 2))
        right = sum(float(scan[-k]) for k in range(1, rays // 2))
        return 0.0, 1.0 if left >= right else -1.0
    return forward, heading / (math.pi / 4)


def _action(
    rng: Any, code: str, obs: dict[str, Any], info: dict[str, Any], backoff: bool
) -> dict[str, Any]:
    from simhost.worlds.track1 import make_action

    if code == "m":
        forward, turn = _move(rng, obs["range_scan"], backoff)
        return make_action("move", forward=forward, turn=turn)
    if code == "n":
        return make_action("noop")
    dets = info["detections"]  # nearest first
    if code == "o":
        ids = [d["id"] for d in dets if d["kind"] in ("door", "container") and d["state"] != "open"]
    else:
        ids = [d["id"] for d in dets if d["kind"] in ("object", "tool")]
    return make_action(PRIM[code], target=ids[0] if ids else 1)


def child_main(config: str, kind: str, seeds: list[int], n: int, warmup: int) -> dict[str, Any]:
    os.environ["MUJOCO_GL"] = "egl"  # before mujoco is imported (HouseEnv imports it lazily)
    import mujoco
    import numpy as np

    from simhost.worlds.track1 import HouseEnv, HouseEnvConfig, HouseParams

    base_kib = _status_kib("VmRSS")
    cfg = HouseEnvConfig()
    per_move = cfg.turn_steps + cfg.forward_steps + cfg.settle_steps
    params = HouseParams.challenge() if kind == "challenge" else HouseParams()
    opts: dict[str, Any] = {"render_rgbd": True, "image_size": IMAGE} if config == "rgbd" else {}
    env = HouseEnv(params=params, **opts)
    clock = time.perf_counter_ns
    out: dict[str, Any] = {"ns": [], "phys": [], "prim": [], "ok": [], "collided": []}
    out["per_move"] = per_move
    rooms: list[int] = []
    visited: list[int] = []
    try:
        for seed in seeds:
            env.reset(seed=seed)
            rooms.append(len(env.layout.rooms))
            if config == "rgbd" and "gl" not in out:
                out["gl"] = _gl_renderer()
            m, d = env.house.sim.model, env.house.sim.data
            if config == "raw":
                step = mujoco.mj_step
                for _ in range(warmup * per_move):
                    step(m, d)
                for _ in range(n):
                    t0 = clock()
                    for _ in range(per_move):
                        step(m, d)
                    out["ns"].append(clock() - t0)
                    out["phys"].append(per_move)
                continue
            for rep, count in (("warm", warmup), ("timed", n)):
                rng = np.random.default_rng(seed)
                obs, info = env.reset(seed=seed)  # same house: no rebuild, initial state
                m, d = env.house.sim.model, env.house.sim.data
                backoff = False
                seen = {info["room"]["id"]}
                for i in range(count):
                    code = MIX[i % len(MIX)]
                    action = _action(rng, code, obs, info, backoff)
                    t_sim = d.time
                    t0 = clock()
                    obs, _, _, _, info = env.step(action)
                    dt = clock() - t0
                    if code == "m":
                        backoff = bool(info["collided"])
                    if rep == "timed":
                        out["ns"].append(dt)
                        out["phys"].append(round((d.time - t_sim) / m.opt.timestep))
                        out["prim"].append(code)
                        out["ok"].append(bool(info["action_result"]["ok"]))
                        out["collided"].append(bool(info["collided"]))
                        seen.add(info["room"]["id"])
                if rep == "timed":
                    visited.append(len(seen))
    finally:
        env.close()
    out.update(
        rooms=rooms,
        visited=visited,
        hwm_kib=_status_kib("VmHWM"),
        rss_kib=_status_kib("VmRSS"),
        base_kib=base_kib,
    )
    return out


# ============================================================================ orchestrator
class Runner:
    """Starts and always reaps the benchmark's child processes."""

    def __init__(self, timeout_s: float) -> None:
        self.timeout_s = timeout_s
        self.procs: list[subprocess.Popen[bytes]] = []
        self.env = dict(
            os.environ,
            PYTHONPATH=os.pathsep.join([str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]),
            PYTHONUNBUFFERED="1",
            MUJOCO_GL="egl",
        )

    def kill_all(self) -> None:
        reap(self.procs)

    def run(self, config: str, kind: str, seeds: list[int], n: int, warmup: int) -> dict[str, Any]:
        argv = [
            sys.executable,
            str(Path(__file__).resolve()),
            "--child",
            config,
            "--kind",
            kind,
            "--seeds",
            ",".join(map(str, seeds)),
            "--n",
            str(n),
            "--warmup",
            str(warmup),
        ]
        return run_child(argv, self.procs, env=self.env, cwd=ROOT, timeout_s=self.timeout_s)


def _q(sorted_ns: list[int], p: float) -> float:
    """Nearest-rank quantile in ms."""
    return sorted_ns[min(len(sorted_ns) - 1, int(round(p * (len(sorted_ns) - 1))))] / 1e6


def _stats(ns: list[int], phys: list[int]) -> dict[str, float]:
    s = sorted(ns)
    total_s = sum(s) / 1e9
    return {
        "n": len(s),
        "rate": len(s) / total_s,
        "median": _q(s, 0.5),
        "p99": _q(s, 0.99),
        "phys_per_step": sum(phys) / len(phys),
        "phys_rate": sum(phys) / total_s,
    }


def _machine() -> str:
    return machine_line("mujoco", "gymnasium", "numpy", extra="MUJOCO_GL=egl")


def _merge(parts: list[dict[str, Any]]) -> dict[str, Any]:
    merged: dict[str, Any] = {k: [] for k in ("ns", "phys", "prim", "ok", "collided")}
    for p in parts:
        for k in merged:
            merged[k].extend(p.get(k, []))
    last = parts[-1]
    merged.update(
        per_move=last["per_move"],
        rooms=last["rooms"],
        visited=last["visited"],
        gl=next((p["gl"] for p in parts if "gl" in p), None),
        hwm_kib=max(p["hwm_kib"] for p in parts),
        base_kib=max(p["base_kib"] for p in parts),
        round_medians=[_q(sorted(p["ns"]), 0.5) for p in parts],
    )
    return merged


def _table(results: dict[tuple[str, str], dict[str, Any] | str], per_move: int) -> list[str]:
    labels = {c: lab.format(k=per_move) for c, lab in CONFIGS}
    head = (
        f"{'configuration':<33} {'house':<9} {'steps/s':>8} {'median ms':>9} {'p99 ms':>8} "
        f"{'x raw':>6} {'phys/step':>9} {'phys/s':>7} {'peak RSS MiB':>12} {'import MiB':>10} "
        f"{'n':>5}  {'round medians':>13}"
    )
    lines = [head, "-" * len(head)]
    for kind in KINDS:
        raw = results.get(("raw", kind))
        raw_med = raw["stats"]["median"] if isinstance(raw, dict) else None
        for c, _ in CONFIGS:
            r = results.get((c, kind))
            if r is None:
                continue
            if isinstance(r, str):
                lines.append(f"{labels[c]:<33} {kind:<9} FAILED: {r.splitlines()[0][:60]}")
                continue
            s = r["stats"]
            ratio = f"{s['median'] / raw_med:.2f}" if raw_med else "-"
            lines.append(
                f"{labels[c]:<33} {kind:<9} {s['rate']:>8.0f} {s['median']:>9.2f} "
                f"{s['p99']:>8.2f} {ratio:>6} {s['phys_per_step']:>9.1f} {s['phys_rate']:>7.0f} "
                f"{r['hwm_kib'] / 1024:>12.1f} {r['base_kib'] / 1024:>10.1f} {s['n']:>5}  "
                f"{min(r['round_medians']):>6.2f}-{max(r['round_medians']):<6.2f}"
            )
        lines.append("")
    lines += [
        f"steps/s: control steps per second of timed time (raw: blocks of {per_move} mj_step, the",
        "  physics of one uncollided move); x raw: median / raw median of the same house kind;",
        "  phys/step: mean physics steps per control step (counted from data.time); phys/s:",
        "  physics steps per second; peak RSS: VmHWM of the configuration's own fresh process",
        "  (max over rounds); import MiB: its VmRSS after importing mujoco, numpy",
        "  and simhost.worlds.track1, before any house is built; round medians:",
        "  lowest-highest median ms of the rounds.",
    ]
    return lines


def _breakdown(results: dict[tuple[str, str], dict[str, Any] | str]) -> list[str]:
    head = f"{'primitive mix':<26} {'house':<9}" + "".join(
        f" {PRIM[c]:>20}" for c in dict.fromkeys(MIX)
    )
    lines = [head, "-" * len(head)]
    for kind in KINDS:
        for c in ("env", "rgbd"):
            r = results.get((c, kind))
            if not isinstance(r, dict):
                continue
            cells = []
            for code in dict.fromkeys(MIX):
                idx = [i for i, p in enumerate(r["prim"]) if p == code]
                if not idx:
                    cells.append(f" {'-':>20}")
                    continue
                med = _q(sorted(r["ns"][i] for i in idx), 0.5)
                ok = sum(r["ok"][i] for i in idx)
                phys = sum(r["phys"][i] for i in idx) / len(idx)
                cells.append(f" {f'{med:.2f}ms {phys:.0f}ph {ok}/{len(idx)}ok':>20}")
            lines.append(f"{c:<26} {kind:<9}" + "".join(cells))
        r = results.get(("env", kind))
        if isinstance(r, dict):
            moves = [i for i, p in enumerate(r["prim"]) if p == "m"]
            hit = sum(r["collided"][i] for i in moves)
            lines.append(
                f"  ({kind}: {hit}/{len(moves)} moves collided; rooms per seed {r['rooms']}, "
                f"visited {r['visited']})"
            )
    lines.append("cells: median ms, mean physics steps, successful attempts / attempts")
    return lines


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer steps, one round (< 30 s)")
    ap.add_argument("--rounds", type=int, default=None, help="interleaved rounds (default 3)")
    ap.add_argument("--seeds", default=",".join(map(str, SEEDS)))
    ap.add_argument("--json", type=Path, default=None, help="also write the stats here")
    # child role (internal)
    ap.add_argument("--child", choices=[c for c, _ in CONFIGS], help=argparse.SUPPRESS)
    ap.add_argument("--kind", choices=KINDS, help=argparse.SUPPRESS)
    ap.add_argument("--n", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--warmup", type=int, default=0, help=argparse.SUPPRESS)
    args = ap.parse_args()
    seeds = [int(s) for s in args.seeds.split(",") if s]
    if args.child:
        die_with_parent()
        out = child_main(args.child, args.kind, seeds, args.n, args.warmup)
        print(json.dumps(out), flush=True)
        return 0

    rounds = max(1, args.rounds or (1 if args.quick else 3))
    which = 1 if args.quick else 0

    def on_term(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, on_term)
    print(_machine())
    counts = ", ".join(
        f"{c} {COUNTS[c][which][0]} (+{COUNTS[c][which][1]} warm-up)" for c, _ in CONFIGS
    )
    print(
        f"seeds {seeds} per house kind; per seed and round: {counts}; {rounds} interleaved "
        f"round(s), one fresh process per configuration, house kind and round; "
        f"load average {load_average()}",
        flush=True,
    )
    t_start = time.monotonic()
    parts: dict[tuple[str, str], list[dict[str, Any]]] = {}
    failed: dict[tuple[str, str], str] = {}
    runner = Runner(timeout_s=45.0 if args.quick else 90.0)
    try:
        for rnd in range(rounds):
            for kind in KINDS:
                for config, _ in CONFIGS:
                    if (config, kind) in failed:
                        continue
                    n, warm = COUNTS[config][which]
                    t0 = time.monotonic()
                    try:
                        out = runner.run(config, kind, seeds, n, warm)
                    except RuntimeError as e:
                        failed[(config, kind)] = str(e)
                        print(f"  {config}/{kind}: FAILED\n{e}", file=sys.stderr)
                        continue
                    parts.setdefault((config, kind), []).append(out)
                    print(
                        f"  round {rnd + 1}/{rounds} {config:<5} {kind:<9} "
                        f"{_q(sorted(out['ns']), 0.5):8.2f} ms median, "
                        f"VmHWM {out['hwm_kib'] / 1024:.0f} MiB ({time.monotonic() - t0:.1f} s)",
                        file=sys.stderr,
                        flush=True,
                    )
    finally:
        runner.kill_all()
    results: dict[tuple[str, str], dict[str, Any] | str] = {}
    for key, ps in parts.items():
        if key in failed:
            continue
        merged = _merge(ps)
        merged["stats"] = _stats(merged["ns"], merged["phys"])
        results[key] = merged
    results.update(failed)
    per_move = next((r["per_move"] for r in results.values() if isinstance(r, dict)), 85)
    print()
    print("\n".join(line.rstrip() for line in _table(results, per_move)))
    print()
    print("\n".join(line.rstrip() for line in _breakdown(results)))
    gl = next((r["gl"] for r in results.values() if isinstance(r, dict) and r.get("gl")), None)
    print(f"\nGL renderer (rgbd): {gl or '?'}; load average {load_average()}")
    print(f"total {time.monotonic() - t_start:.0f} s")
    if args.json:
        args.json.write_text(
            json.dumps(
                {
                    f"{c}/{k}": (
                        {
                            **r["stats"],
                            "peak_rss_mib": r["hwm_kib"] / 1024,
                            "import_rss_mib": r["base_kib"] / 1024,
                            "round_medians_ms": r["round_medians"],
                        }
                        if isinstance(r, dict)
                        else r
                    )
                    for (c, k), r in results.items()
                },
                indent=1,
            )
        )
    return 0 if all(isinstance(r, dict) for r in results.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
