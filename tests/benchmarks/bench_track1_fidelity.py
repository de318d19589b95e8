#!/usr/bin/env python
"""Track 1 calibration (issue 11): our Table IV beside the paper's, on any seed range.

    python tests/benchmarks/bench_track1_fidelity.py [--standard A:B] [--challenge A:B]
        [--agents sanity,heuristic,memoryfree,lookahead,structured,oracle,nothing,vision]
        [--workers 2] [--cap N] [--render] [--json out.json] [--vision A:B]

- ``--standard A:B`` / ``--challenge A:B``: the seeds of each official split (Python range
  notation, B excluded; default 0:40 each). Hidden campaigns draw their seeds from an HMAC,
  so any range is a fair sample; check several disjoint ranges before trusting a figure.
- ``--agents``: which systems (default: all). ``sanity``, ``heuristic``, ``memoryfree``,
  ``lookahead``, ``structured`` are the baselines of ``examples/track1_*`` (the very code of
  their images); ``oracle`` is a privileged agent that reads the live episode's ground truth
  (``_track1_oracle.py``: it shows the tasks are solvable within the step budgets) and
  ``nothing`` ends every stage at once.
- ``--workers``: processes in parallel (default 2, one per core here).
- ``--cap N``: a campaign-wide step cap per stage on top of the episodes' own budgets (none
  by default: the official runs have none).
- ``--render``: render the egocentric RGB-D + segmentation the official splits carry. Off
  by default: no baseline reads images, rendering changes nothing in the simulation, and it
  is two thirds of a step's cost.
- ``--json``: also write every episode's figures (its score card's components and
  metrics: the parts of the model and recovery scores among them).
- ``--vision A:B``: also play the ``vision`` extra split (pixels in, actions by pixel,
  files matched to the truth by position) on these seeds with the systems that act by pixel
  (``oracle``, ``nothing`` and ``vision``, the learned-vision baseline of
  ``examples/track1_vision``, which plays only this split; the other baselines name ids),
  and print its Table IV rows beside the structured planner's on ``standard`` (the same
  houses and tasks with a detector handed over) with the median decision time and the
  peak memory of the playing process above do-nothing's, and the checks: oracle >= 95,
  do-nothing 0, the learned-vision baseline above the sanity agent's Final by two standard
  errors. Frames are always rendered on ``vision``.
- ``--unstratified``: each seed draws its exception, as a one-off episode does. By default
  the ``k``-th seed of a split's range is episode index ``k``, as in a campaign, and the
  index decides the exception type (``plugins/track1/_scenario.py``); the report says how
  often a house could not hold its index's type (the task then fits the next type).

Every episode is played in process by ``_track1_harness.DirectEnv``: the sim host's rules
(stages, step budgets, action checks, invalid actions, /output snapshots with the worker's
own ``collect``) and the plugin's own scoring, without Zenoh, the container and wall-clock
budgets (``tests/plugins/test_track1_baselines.py`` checks that an episode scores the same
there as through the real worker). Each agent runs in child processes of its own (its
example folder first on the path), several episodes per child.

Prints, per system, our row (mean over the episodes: Std., Ch., Final = 0.6 Std. + 0.4 Ch.,
task success %, model verification %, recovery % over the episodes with an exception,
invalid actions per episode, median agent decision time in ms) above the paper's, then the
calibration checks: final within 10 points of the paper, Table IV's order, the heuristic
above the memory-free policy on model and recovery, the structured planner highest on both,
oracle >= 95 and nothing <= 5 on both splits, and the same score for the same seed twice.
Each Final check also gives the Final's standard error (from the spread of the episodes'
scores): on 20 + 20 seeds it is 4-5 points for the baselines (3-3.7 on 40 + 40), so a
check missed by less than that may be chance alone. Then each system's final with its 95 %
interval and, for each pair of neighbours in Table IV's order, the paired probability that
they are in that order, and the paired spread per split (``tests/benchmarks/_uncertainty``).

Not collected by pytest (the file is ``bench_*.py``). With 2 workers on 2 cores: 4-5 min
for 40 + 40 seeds of every system on a quiet machine, about 8 while the test suite runs
beside it; one system alone is a fifth to a tenth of that.
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from _machine import die_with_parent, load_average, machine_line  # noqa: E402  (sibling)
from _uncertainty import paired_spread, uncertainty_lines  # noqa: E402  (sibling)

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
SYSTEMS = ("sanity", "heuristic", "memoryfree", "lookahead", "structured", "oracle", "nothing",
           "vision")
#: Table IV's order of finals, lowest first, and eq. 2's split weights.
ORDER = ("sanity", "heuristic", "memoryfree", "lookahead", "structured")
WEIGHTS = {"standard": 0.6, "challenge": 0.4}
NAMES = {"sanity": "Random sanity", "heuristic": "Heuristic planner",
         "memoryfree": "Memory-free policy", "lookahead": "PathDreamer-style",
         "structured": "Structured WM+replan", "oracle": "Oracle (privileged)",
         "nothing": "Do-nothing", "vision": "Learned vision"}
PAPER = {  # Table IV: Std., Ch., Final, Task Succ. %, Model Verif. %, Recovery %, Invalid/Ep
    "sanity": (10.6, 6.8, 9.1, 2.5, 10.0, 0.0, 27.4),
    "heuristic": (32.8, 23.9, 29.2, 27.8, 44.0, 13.5, 13.6),
    "memoryfree": (33.5, 24.2, 29.8, 31.6, 20.5, 8.8, 12.4),
    "lookahead": (40.6, 30.8, 36.7, 34.8, 35.0, 18.2, 10.7),
    "structured": (48.2, 36.5, 43.5, 41.0, 58.0, 31.5, 8.4),
}
CHUNK = 5


# ============================================================================ children
def child(system: str, split: str, seeds: list[tuple[int, int | None]], cap: int | None,
          render: bool) -> None:
    """Plays episodes in this process and prints one JSON line per episode."""
    die_with_parent()
    os.environ.setdefault("MUJOCO_GL", "egl")
    sys.path.insert(0, str(HERE))
    from _track1_harness import median, run_agent
    from _track1_oracle import DoNothing, Oracle

    if system == "oracle":
        make = Oracle
    elif system == "nothing":
        make = DoNothing
    else:
        sys.path.insert(0, str(ROOT / "examples" / f"track1_{system}"))
        agent = importlib.import_module("agent")
        make = lambda episode: agent.Agent()  # noqa: E731
    for seed, index in seeds:
        t0 = time.perf_counter()
        p = run_agent(make, split, seed, max_steps_per_stage=cap, render=render, index=index)
        card = p.card
        peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(json.dumps({
            "system": system, "split": split, "seed": seed, "total": card.total,
            "success": card.metrics.get("task_success", 0.0),
            "model": card.metrics.get("model_verification", 0.0),
            "recovery": card.metrics.get("recovery"), "invalid": p.invalid_actions,
            "latency_ms": median(p.latencies_ms), "steps": p.steps, "status": p.status.value,
            "exception": p.exception, "planned": p.planned, "index": index,
            "error": p.error, "wall_s": time.perf_counter() - t0, "peak_mb": peak_mb,
            "components": card.components, "metrics": card.metrics}), flush=True)


def _run_child(system: str, split: str, seeds: list[tuple[int, int | None]], cap: int | None,
               render: bool) -> list[dict[str, Any]]:
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", system, split,
           ",".join(f"{s}:{'' if i is None else i}" for s, i in seeds)]
    if cap is not None:
        cmd += ["--cap", str(cap)]
    if render:
        cmd.append("--render")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)}
    out = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
    rows = [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]
    if len(rows) != len(seeds):
        tail = "\n".join(out.stderr.splitlines()[-5:])
        raise RuntimeError(f"{system} {split} {seeds}: {len(rows)} results\n{tail}")
    return rows


# ============================================================================ the table
def _mean(values: list[float]) -> float:
    return statistics.fmean(values) if values else float("nan")


def _final_se(standard: list[dict[str, Any]], challenge: list[dict[str, Any]]) -> float:
    """The standard error of the Final (points) from the spread of the episodes' scores: how
    far another sample of as many seeds may land by chance alone."""
    var = 0.0
    for weight, results in ((0.6, standard), (0.4, challenge)):
        if len(results) < 2:
            return float("nan")
        var += weight ** 2 * statistics.variance([r["total"] for r in results]) / len(results)
    return 100 * math.sqrt(var)


def row(results: list[dict[str, Any]]) -> dict[str, float]:
    by = {s: [r for r in results if r["split"] == s] for s in ("standard", "challenge")}
    std = 100 * _mean([r["total"] for r in by["standard"]])
    ch = 100 * _mean([r["total"] for r in by["challenge"]])
    recovery = [r["recovery"] for r in results if r["recovery"] is not None]
    return {"std": std, "ch": ch, "final": 0.6 * std + 0.4 * ch,
            "final_se": _final_se(by["standard"], by["challenge"]),
            "success": 100 * _mean([r["success"] for r in results]),
            "model": 100 * _mean([r["model"] for r in results]),
            "recovery": 100 * _mean(recovery), "invalid": _mean([r["invalid"] for r in results]),
            "latency": statistics.median([r["latency_ms"] for r in results])}


def table(rows: dict[str, dict[str, float]]) -> list[str]:
    head = f"{'system':21s}{'':6s}{'Std.':>6s}{'Ch.':>6s}{'Final':>6s}{'Succ%':>6s}" \
           f"{'Model%':>7s}{'Rec%':>6s}{'Inv/Ep':>7s}{'ms':>6s}"
    lines = [head, "-" * len(head)]
    for system, r in rows.items():
        values = (r["std"], r["ch"], r["final"], r["success"], r["model"], r["recovery"])
        lines.append(f"{NAMES[system][:20]:21s}{'ours':6s}"
                     + "".join(f"{v:6.1f}" if k != 4 else f"{v:7.1f}"
                               for k, v in enumerate(values))
                     + f"{r['invalid']:7.1f}{r['latency']:6.1f}")
        if system in PAPER:
            p = PAPER[system]
            lines.append(f"{'':21s}{'paper':6s}" + "".join(
                f"{v:6.1f}" if k != 4 else f"{v:7.1f}" for k, v in enumerate(p[:6]))
                + f"{p[6]:7.1f}")
    return lines


VISION_SYSTEMS = ("oracle", "nothing", "vision")
"""The systems that act by pixel: the oracle, do-nothing and the learned-vision baseline
(``examples/track1_vision``; the other baselines name things by id and play only the
official splits)."""


def vision_lines(results: list[dict[str, Any]], rows: dict[str, dict[str, float]]
                 ) -> tuple[list[str], list[tuple[str, bool]]]:
    """The ``vision`` split's Table IV row per system (its one split is the Final), beside
    the structured planner's on ``standard`` (the same houses and tasks with a detector
    handed over) when it played; the peak memory of the playing process above
    do-nothing's (the simulator's share), and the checks: oracle >= 95, do-nothing 0, the
    learned-vision baseline clearly above the sanity agent (by two standard errors)."""
    head = (f"{'system':21s}{'split':9s}{'Final':>6s}{'Succ%':>6s}{'Model%':>7s}{'Rec%':>6s}"
            f"{'Inv/Ep':>7s}{'ms':>6s}{'+MB':>6s}{'n':>4s}")
    lines = [head, "-" * len(head)]
    floor = max((r["peak_mb"] for r in results if r["system"] == "nothing"), default=None)
    means: dict[str, tuple[float, float]] = {}
    for system in VISION_SYSTEMS:
        mine = [r for r in results if r["system"] == system]
        if not mine:
            continue
        totals = [100 * r["total"] for r in mine]
        se = statistics.stdev(totals) / math.sqrt(len(totals)) if len(totals) > 1 else math.nan
        means[system] = (_mean(totals), se)
        recovery = [r["recovery"] for r in mine if r["recovery"] is not None]
        extra = (max(r["peak_mb"] for r in mine) - floor) if floor is not None else math.nan
        lines.append(f"{NAMES[system][:20]:21s}{'vision':9s}{means[system][0]:6.1f}"
                     f"{100 * _mean([r['success'] for r in mine]):6.1f}"
                     f"{100 * _mean([r['model'] for r in mine]):7.1f}"
                     f"{100 * _mean(recovery):6.1f}{_mean([r['invalid'] for r in mine]):7.1f}"
                     f"{statistics.median([r['latency_ms'] for r in mine]):6.0f}"
                     f"{extra:6.0f}{len(mine):4d}")
    if "structured" in rows:
        r = rows["structured"]
        lines.append(f"{NAMES['structured'][:20]:21s}{'standard':9s}{r['std']:6.1f}"
                     f"{r['success']:6.1f}{r['model']:7.1f}{r['recovery']:6.1f}"
                     f"{r['invalid']:7.1f}{r['latency']:6.0f}")
    out = []
    if "oracle" in means:
        out.append((f"oracle >= 95 on vision ({means['oracle'][0]:.1f})",
                    means["oracle"][0] >= 95))
    if "nothing" in means:
        out.append((f"do-nothing 0 on vision ({means['nothing'][0]:.1f})",
                    means["nothing"][0] == 0))
    if "vision" in means:  # our sanity agent's Final when it played, else the paper's
        sanity, whose = ((rows["sanity"]["final"], "ours") if "sanity" in rows
                         else (PAPER["sanity"][2], "the paper's"))
        got, se = means["vision"]
        out.append((f"learned vision {got:.1f} above sanity's final ({whose}, {sanity:.1f}) "
                    f"by 2 s.e. ({se:.1f})", got - 2 * se > sanity))
    return lines, out


def checks(rows: dict[str, dict[str, float]], repeat: tuple[str, float, float] | None
           ) -> list[tuple[str, bool]]:
    out: list[tuple[str, bool]] = []
    for system in PAPER:
        if system in rows:
            got, want = rows[system]["final"], PAPER[system][2]
            se = rows[system]["final_se"]
            out.append((f"{system}: final {got:.1f} within 10 of {want} (s.e. {se:.1f})",
                        abs(got - want) <= 10))
    baselines = [s for s in PAPER if s in rows]
    if len(baselines) == len(PAPER):
        f = {s: rows[s]["final"] for s in baselines}
        out.append(("order: sanity < heuristic, memory-free < look-ahead < structured",
                    f["sanity"] < min(f["heuristic"], f["memoryfree"])
                    and max(f["heuristic"], f["memoryfree"]) < f["lookahead"] < f["structured"]))
        h, m, s = rows["heuristic"], rows["memoryfree"], rows["structured"]
        out.append(("heuristic above memory-free on model and recovery",
                    h["model"] > m["model"] and h["recovery"] > m["recovery"]))
        out.append(("structured highest on model and recovery",
                    all(s["model"] >= rows[x]["model"] and s["recovery"] >= rows[x]["recovery"]
                        for x in baselines)))
    if "oracle" in rows:
        o = rows["oracle"]
        out.append((f"oracle >= 95 on both splits ({o['std']:.1f}, {o['ch']:.1f})",
                    min(o["std"], o["ch"]) >= 95))
    if "nothing" in rows:
        n = rows["nothing"]
        out.append((f"do-nothing <= 5 on both splits ({n['std']:.1f}, {n['ch']:.1f})",
                    max(n["std"], n["ch"]) <= 5))
    if repeat is not None:
        name, a, b = repeat
        out.append((f"same seed, same score ({name}: {a:.4f} and {b:.4f})", a == b))
    return out


def mix_lines(rows: list[dict[str, Any]], systems: list[str]) -> list[str]:
    """How a campaign's exception mix moves its final: the fallbacks (an index's type the
    house could not hold), each system's final across disjoint 20 + 20 blocks of the run,
    and, from the same episodes, the final's spread over 20 + 20 episodes with the mix
    drawn per seed (total variance) and stratified by index (within-type variance)."""
    from plugins import load_track
    from plugins.track1._scenario import stratified_exception
    from plugins.track1._types import EXCEPTION_TYPES

    splits = load_track("track1").splits
    indexed = [r for r in rows if r.get("index") is not None]
    out = [""]
    if indexed:
        miss = [r for r in indexed if r["planned"] != stratified_exception(
            r["index"], float(splits[r["split"]][1]["exception_probability"]),
            EXCEPTION_TYPES)]
        out.append(f"exception mix by index: {len(miss)} of {len(indexed)} episodes "
                   "planned another type than their index's (the house could not hold it)")
    out.append(f"  {'system':22s}{'blocks':>7s}{'sd':>6s}{'sd, drawn':>11s}"
               f"{'sd, by index':>14s}   (final over 20 + 20 episodes)")
    for system in systems:
        mine = [r for r in rows if r["system"] == system]
        by = {s: sorted((r for r in mine if r["split"] == s), key=lambda r: r["seed"])
              for s in WEIGHTS}
        blocks = min(len(v) for v in by.values()) // 20
        finals = [sum(w * 100 * statistics.mean(r["total"] for r in by[s][b * 20:b * 20 + 20])
                      for s, w in WEIGHTS.items()) for b in range(blocks)]
        drawn = within = 0.0
        for s, w in WEIGHTS.items():
            scores = [100 * r["total"] for r in by[s]]
            if len(scores) < 2:
                break
            drawn += w ** 2 * statistics.variance(scores) / 20
            types: dict[str | None, list[float]] = {}
            for r in by[s]:
                types.setdefault(r["planned"], []).append(100 * r["total"])
            within += w ** 2 * sum(len(v) * statistics.pvariance(v) for v in types.values()
                                   ) / len(scores) / 20
        sd = f"{statistics.stdev(finals):6.1f}" if blocks > 1 else f"{'-':>6s}"
        out.append(f"  {NAMES[system][:21]:22s}{blocks:7d}{sd}{math.sqrt(drawn):11.1f}"
                   f"{math.sqrt(within):14.1f}")
    return out


# ============================================================================ main
def _range(text: str) -> list[int]:
    a, b = (int(x) for x in text.split(":"))
    if not 0 <= a < b:
        raise argparse.ArgumentTypeError(f"{text!r}: want A:B with 0 <= A < B")
    return list(range(a, b))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--standard", type=_range, default=_range("0:40"), metavar="A:B")
    ap.add_argument("--challenge", type=_range, default=_range("0:40"), metavar="A:B")
    ap.add_argument("--agents", default=",".join(SYSTEMS))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--cap", type=int, default=None)
    ap.add_argument("--render", action="store_true")
    ap.add_argument("--unstratified", action="store_true")
    ap.add_argument("--vision", type=_range, default=None, metavar="A:B")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--child", nargs=3, metavar=("SYSTEM", "SPLIT", "SEEDS"),
                    help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        system, split, seeds = args.child
        pairs = [s.split(":") for s in seeds.split(",")]
        child(system, split, [(int(s), int(i) if i else None) for s, i in pairs], args.cap,
              args.render)
        return
    systems = [s.strip() for s in args.agents.split(",") if s.strip()]
    unknown = [s for s in systems if s not in SYSTEMS]
    if unknown:
        ap.error(f"unknown systems {unknown}; known: {', '.join(SYSTEMS)}")
    print(machine_line("mujoco", "numpy", extra=f"load {load_average()}"))
    print(f"standard seeds {args.standard[0]}-{args.standard[-1]} ({len(args.standard)}), "
          f"challenge seeds {args.challenge[0]}-{args.challenge[-1]} "
          f"({len(args.challenge)}), {args.workers} workers, "
          f"images {'rendered' if args.render else 'not rendered'}")
    jobs = []
    for system in systems:
        for split, seeds in (("standard", args.standard), ("challenge", args.challenge)):
            if system == "vision":  # plays the vision split only
                break
            indexed = [(s, None if args.unstratified else k) for k, s in enumerate(seeds)]
            jobs += [(system, split, indexed[k:k + CHUNK]) for k in range(0, len(seeds), CHUNK)]
        if args.vision and system in VISION_SYSTEMS:
            indexed = [(s, None if args.unstratified else k) for k, s in enumerate(args.vision)]
            jobs += [(system, "vision", indexed[k:k + CHUNK])
                     for k in range(0, len(indexed), CHUNK)]
    first = next((s for s in ("structured", "heuristic") if s in systems),
                 next((s for s in systems if s not in ("nothing", "vision")), None))
    if first is not None:
        jobs.append((f"repeat:{first}", "standard",
                     [(args.standard[0], None if args.unstratified else 0)]))
    t0 = time.perf_counter()
    done = 0

    def run(job: tuple[str, str, list[int]]) -> list[dict[str, Any]]:
        nonlocal done
        system, split, seeds = job
        rows = _run_child(system.removeprefix("repeat:"), split, seeds, args.cap, args.render)
        for r in rows:
            r["repeat"] = system.startswith("repeat:")
        done += 1
        print(f"  {done}/{len(jobs)} {system} {split} {seeds[0][0]}..{seeds[-1][0]} "
              f"({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)
        return rows

    with ThreadPoolExecutor(max_workers=args.workers) as pool:
        results = [r for rows in pool.map(run, jobs) for r in rows]
    vision_rows = [r for r in results if r["split"] == "vision"]
    main_rows = [r for r in results if not r["repeat"] and r["split"] != "vision"]
    rows = {s: row([r for r in main_rows if r["system"] == s]) for s in systems
            if s != "vision"}
    again = next((r for r in results if r["repeat"]), None)
    repeat = None
    if again is not None:
        once = next(r for r in main_rows if r["system"] == again["system"]
                    and r["split"] == "standard" and r["seed"] == again["seed"])
        repeat = (f"{again['system']} standard seed {again['seed']}", once["total"],
                  again["total"])
    errors = [r for r in main_rows if r["error"]]
    print()
    print(f"Track 1, Table IV (ours above the paper's), {time.perf_counter() - t0:.0f} s")
    print("\n".join(table(rows)))
    print("\nCalibration checks:")
    vlines, vchecks = vision_lines(vision_rows, rows) if args.vision else ([], [])
    for text, ok in checks(rows, repeat) + vchecks:
        print(f"  {'ok  ' if ok else 'FAIL'} {text}")
    if vlines:
        print(f"\nThe vision split, seeds {args.vision[0]}-{args.vision[-1]} (outside the "
              "final; +MB: peak memory above do-nothing's process):")
        print("\n".join(vlines))
    episodes = {s: {(r["split"], r["seed"]): ("", 100 * r["total"]) for r in main_rows
                    if r["system"] == s} for s in systems if s != "vision"}
    print("\n".join(uncertainty_lines(episodes, ORDER, WEIGHTS, NAMES)))
    spread = paired_spread(episodes, ORDER)
    if spread:
        print("  paired spread, rms over neighbours (Track1.reference_spread): "
              + ", ".join(f"{s} {v:.1f}" for s, v in spread.items()))
    print("\n".join(mix_lines(main_rows, [s for s in systems if s in ORDER])))
    if errors:
        print(f"\n{len(errors)} episodes ended with an agent error, e.g. "
              f"{errors[0]['system']} {errors[0]['split']} {errors[0]['seed']}: "
              f"{errors[0]['error'][:60]}")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "episodes": [
            r for r in results if r["split"] != "vision"],
            **({"vision": vision_rows} if args.vision else {})}, indent=1))


if __name__ == "__main__":
    main()
