#!/usr/bin/env python
"""Track 2 calibration (issue 12): our Table VII beside the paper's, on any seed range.

    python tests/benchmarks/bench_track2_fidelity.py [--first-seed N] [--per-family K]
        [--splits standard,challenge] [--agents oracle,nothing,imitation,...]
        [--jobs 2] [--json FILE] [--inproc] [--keep-runs]

For every split, episode ``i`` of ``5 K`` has seed ``first_seed + i`` and index ``i`` (so
family ``i mod 5``: ``K`` instances of each family per split), exactly as a campaign's
``make_scenario(seed=..., index=i)`` would draw it. Every agent meets the same episodes:

- the baselines of ``examples/track2_*`` run as local processes through the real worker
  (``run_episode`` with the local-process runtime, the real sim host, Zenoh, the packet in
  ``$EAGC_INPUT``), unscaled official budgets, scored by the plugin: the same agent code and
  the same scoring path as a campaign, without the container;
- ``oracle`` (in-process, privileged): the scripted expert reading the simulation's exact
  state, and the true task model; ``nothing``: an agent that writes no file and never
  moves (it holds still through every attempt). Both go through the plugin's ``score``.

Targets (issues 12, 36): Avg within ±10 of the paper (imitation 28.7, waypoint 32.5, demo
parser 36.6, trajectory 47.1, task model 50.8) and in the same order; success well below
100 %; the task-model baseline highest on task-model %; attempts between 1.5 and 3; oracle
>= 95 and nothing <= 5 on every split; the benchmark prints each as ``ok`` or ``FAIL``
after the tables (same seed, same episode is covered by the tests). Check them on several
disjoint seed ranges: the organizers' seeds are hidden, and with 4 instances per family
per split one range's Avg moves by 10-15 points from the next (the report's intervals say
how far). Time on the project's 2-core machine: well under 1 s per in-process episode and
2-4 s per baseline episode; the default with the four baselines of before the trajectory
baseline (8 per family, 2 splits: 480 episodes, 2 jobs) took 17-19 minutes while other
jobs kept the load average at 9-12; ``--per-family 4 --inproc`` (240 episodes) takes 4-6
minutes at a load average of 4-8. The episodes' folders (logs, files, MCAP) go to a
temporary folder removed at the end; ``--keep-runs`` keeps it and prints where.
Not collected by pytest (the file is ``bench_*.py``).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")
ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from _machine import load_average, machine_line  # noqa: E402  (sibling)
from _uncertainty import paired_spread, uncertainty_lines  # noqa: E402  (sibling)

BASELINES = {"imitation": "track2_imitation", "waypoint": "track2_waypoint",
             "demoparser": "track2_demoparser", "trajectory": "track2_trajectory",
             "taskmodel": "track2_taskmodel"}
PAPER = {  # Table VII: families, Avg, Succ %, Task Model %, Attempts, Adapt. min
    "imitation": (31.4, 34.8, 22.6, 36.5, 18.2, 28.7, 25.0, 12.0, 2.8, 2.1),
    "waypoint": (35.2, 37.9, 27.5, 40.8, 21.3, 32.5, 30.5, 15.0, 2.6, 2.4),
    "demoparser": (42.6, 39.7, 31.0, 44.5, 25.2, 36.6, 34.0, 46.0, 2.4, 3.8),
    "trajectory": (53.5, 49.0, 40.4, 55.8, 36.7, 47.1, 44.5, 32.0, 2.1, 4.6),
    "taskmodel": (57.8, 52.4, 43.6, 59.5, 40.6, 50.8, 48.0, 55.0, 1.9, 5.5),
}
LABELS = {"oracle": "oracle", "nothing": "nothing", "imitation": "T-OSVI im.",
          "waypoint": "AWDA wayp.", "demoparser": "demo-parser", "trajectory": "OSVI-WM tr.",
          "taskmodel": "OSVI-WM+TM"}
KEYS = ("insertion", "rotation", "assembly", "opening", "tool_use", "final", "task_success",
        "task_model", "attempts", "adapt_time_min")


# ----------------------------------------------------------------- one episode, any agent
def run_one(agent: str, split: str, seed: int, index: int, runs: str,
            inproc: bool = False) -> dict[str, Any]:
    """Plays one episode and returns its ``EpisodeResult`` as JSON."""
    if agent in ("oracle", "nothing"):
        return _in_process(agent, split, seed, index).model_dump(mode="json")
    if inproc:
        from _track2_inproc import run_inproc

        return run_inproc(BASELINES[agent], seed=seed, split=split, index=index)
    from orchestrator._episode.worker import EpisodeSpec, run_episode
    from orchestrator._runtimes.local import LocalProcessRuntime
    from schemas import Limits

    spec = EpisodeSpec(track="track2", image=f"python examples/{BASELINES[agent]}/agent.py",
                       seed=seed, split=split, index=index, params={"demo_frames": False},
                       limits=Limits(startup_s=60.0, pin_cpus=False), runs_dir=Path(runs),
                       exit_grace_s=5.0)
    result = run_episode(spec, LocalProcessRuntime(quiet=True))
    return result.model_dump(mode="json")


def _in_process(agent: str, split: str, seed: int, index: int) -> Any:
    """The oracle or the do-nothing agent, driving the episode as the host would."""
    import numpy as np

    from plugins import load_track, score_episode
    from plugins.track2 import Track2Scenario
    from plugins.track2._episode import DEMONSTRATION, EXECUTION, PARSING
    from schemas import EpisodeResult, EpisodeStats, EpisodeStatus, TaskModel
    from simhost.worlds.track2 import ScriptedExpert, task_truth

    started = time.time()
    plugin = load_track("track2")
    scenario = plugin.make_scenario(seed=seed, split=split, params={"demo_frames": False},
                                    index=index)
    ep = plugin.make_episode(scenario)
    steps = 0
    files: dict[str, Any] = {}
    try:
        ep.reset()
        for stage in (DEMONSTRATION, PARSING):
            ep.on_stage_start(stage)
            if stage == PARSING and agent == "oracle":
                hidden = Track2Scenario.model_validate(scenario.params)
                truth = task_truth(hidden.instance, hidden.bench)
                files["task_model.json"] = TaskModel(
                    family=truth.family, stages=list(truth.stages),
                    variables=[v.model_dump() for v in truth.state_variables],
                    constraints=[c.model_dump() for c in truth.constraints],
                    preconditions=[{"stage": k, "requires": list(v)}
                                   for k, v in truth.preconditions.items()],
                    success_criteria=[c.model_dump() for c in truth.success])
            ep.on_stage_end(stage, ended_by="agent", payload={})
        ep.on_stage_start(EXECUTION)
        over, attempt, expert = False, 0, None
        budget = ep.step_budget(EXECUTION) or 10**6
        while not over and steps < budget:
            data = ep.observe().data
            if data["attempt"] != attempt:
                attempt = data["attempt"]
                expert = ScriptedExpert(ep.env) if agent == "oracle" else None
            if expert is not None:
                motion = expert()
            else:  # hold still, fingers as they are
                motion = np.array([0, 0, 0, 0, 2 * ep.env.sim.width() / 0.09 - 1], np.float32)
            out = ep.step(EXECUTION, {"motion": np.clip(motion, -1, 1).astype(np.float32)})
            steps += 1
            over = out.episode_over
        ep.on_stage_end(EXECUTION, ended_by="episode_over" if over else "steps", payload={})
        outcome = ep.outcome()
    finally:
        ep.close()
    card = score_episode(
        plugin, scenario, status=EpisodeStatus.COMPLETED, end_reason="completed",
        stages_reached=(DEMONSTRATION, PARSING, EXECUTION), outcome=outcome, files=files,
        snapshots={}, steps=steps, invalid_actions=0, protocol_errors=0)
    return EpisodeResult(
        episode=f"{agent}-{split}-{seed}", track="track2", split=split, image=agent,
        runtime="in-process", status=EpisodeStatus.COMPLETED, score=card,
        stats=EpisodeStats(steps=steps, wall_s=time.time() - started),
        started_at=started, finished_at=time.time())


# ----------------------------------------------------------------- the table
def _fmt(v: float | None, width: int, digits: int = 1) -> str:
    return f"{'-':>{width}}" if v is None else f"{v:>{width}.{digits}f}"


def table(rows: dict[str, dict[str, float | None]], title: str) -> list[str]:
    head = (f"{'system':<12}{'Ins':>6}{'Rot':>6}{'Asm':>6}{'O/C':>6}{'Tool':>6}{'Avg':>6}"
            f"{'Succ%':>7}{'TM%':>6}{'Att':>5}{'Adapt':>7}")
    out = [title, head, "-" * len(head)]
    for agent, row in rows.items():
        vals = [row.get(k) for k in KEYS]
        line = f"{LABELS.get(agent, agent):<12}" + "".join(_fmt(v, 6) for v in vals[:6])
        line += _fmt(vals[6], 7) + _fmt(vals[7], 6) + _fmt(vals[8], 5) + _fmt(vals[9], 7, 2)
        out.append(line)
        if agent in PAPER:
            p = PAPER[agent]
            line = f"{'  paper':<12}" + "".join(_fmt(v, 6) for v in p[:6])
            line += _fmt(p[6], 7) + _fmt(p[7], 6) + _fmt(p[8], 5) + _fmt(p[9], 7, 2)
            out.append(line)
    return out


def checks(by_split: dict[str, dict[str, dict[str, float | None]]]) -> list[tuple[str, bool]]:
    """Issue 12's targets on this sample: (what, holds). ``by_split``: split (and "all") →
    agent → the summary row of the table."""
    rows = by_split["all"]
    out: list[tuple[str, bool]] = []
    baselines = [a for a in PAPER if a in rows and rows[a].get("final") is not None]
    for a in baselines:
        got, want = rows[a]["final"] or 0.0, PAPER[a][5]
        out.append((f"{a}: Avg {got:.1f} within 10 of {want}", abs(got - want) <= 10))
    if len(baselines) > 1:
        avgs = [rows[a]["final"] or 0.0 for a in baselines]
        out.append((f"order: {' < '.join(baselines)}",
                    all(x < y for x, y in zip(avgs, avgs[1:], strict=False))))
        top = max(rows[a]["task_success"] or 0.0 for a in baselines)
        out.append((f"success below 100 % for every baseline (highest {top:.1f})", top < 100))
        if "taskmodel" in baselines:
            tm = {a: rows[a]["task_model"] or 0.0 for a in baselines}
            out.append((f"task model highest on task model % ({tm['taskmodel']:.1f})",
                        tm["taskmodel"] >= max(tm.values())))
        att = [rows[a]["attempts"] or 0.0 for a in baselines]
        out.append((f"attempts between 1.5 and 3 ({min(att):.1f}-{max(att):.1f})",
                    all(1.5 <= x <= 3 for x in att)))
    splits = [s for s in by_split if s != "all"]
    for agent, test, word in (("oracle", lambda v: v >= 95, ">= 95"),
                              ("nothing", lambda v: v <= 5, "<= 5")):
        if agent in rows:
            vals = [by_split[s][agent]["final"] or 0.0 for s in splits]
            shown = ", ".join(f"{v:.1f}" for v in vals)
            out.append((f"{agent} {word} on every split ({shown})", all(map(test, vals))))
    return out


def summarize(results: Sequence[dict[str, Any]]) -> dict[str, float | None]:
    from plugins import load_track
    from schemas import EpisodeResult

    extra = ("outcome", "error")  # what the in-process runner adds beside the result
    return load_track("track2").summarize([
        EpisodeResult.model_validate({k: v for k, v in r.items() if k not in extra})
        for r in results])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--first-seed", type=int, default=1000, help="seed of episode 0")
    ap.add_argument("--per-family", type=int, default=8, help="instances per family per split")
    ap.add_argument("--splits", default="standard,challenge")
    ap.add_argument("--agents", default="oracle,nothing,imitation,waypoint,demoparser,"
                    "trajectory,taskmodel",
                    help="comma-separated; baselines need examples/track2_*")
    ap.add_argument("--jobs", type=int, default=2, help="episodes run in parallel")
    ap.add_argument("--json", type=Path, default=None, help="also write every result here")
    ap.add_argument("--inproc", action="store_true", help="run the baselines' code in the "
                    "benchmark's processes (no worker, Zenoh or agent process: quicker)")
    ap.add_argument("--keep-runs", action="store_true", help="keep the episodes' folders "
                    "(logs, files, MCAP) and print where; removed at the end by default")
    args = ap.parse_args()
    splits = args.splits.split(",")
    agents = [a for a in args.agents.split(",") if a in ("oracle", "nothing")
              or (ROOT / "examples" / BASELINES.get(a, "-") / "agent.py").is_file()]
    n = 5 * args.per_family
    print(machine_line("mujoco", "numpy"))
    print(f"seeds {args.first_seed}..{args.first_seed + n - 1} (index 0..{n - 1}) per split, "
          f"splits {', '.join(splits)}; agents {', '.join(agents)}; {args.jobs} jobs; "
          f"load average {load_average()}")
    t0 = time.monotonic()
    runs = tempfile.mkdtemp(prefix="eagc-t2b-", dir="/tmp")
    tasks = [(a, s, args.first_seed + i, i, runs, args.inproc) for a in agents for s in splits
             for i in range(n)]
    results: list[tuple[tuple[Any, ...], dict[str, Any]]] = []
    try:
        with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            futures = [pool.submit(run_one, *t) for t in tasks]
            for k, (t, f) in enumerate(zip(tasks, futures, strict=True)):
                results.append((t, f.result()))
                if (k + 1) % 20 == 0:
                    print(f"  {k + 1}/{len(tasks)} episodes ({time.monotonic() - t0:.0f} s)",
                          file=sys.stderr, flush=True)
    finally:
        if args.keep_runs:
            print(f"episode folders kept in {runs}", file=sys.stderr)
        else:
            shutil.rmtree(runs, ignore_errors=True)
    failed = [(t[0], t[1], t[2], r.get("error") or r["status"]) for t, r in results
              if r["status"] != "completed" or r.get("error")]
    by_split: dict[str, dict[str, dict[str, float | None]]] = {}
    for split in [*splits, "all"]:
        rows = {a: summarize([r for t, r in results if t[0] == a
                              and (split == "all" or t[1] == split)]) for a in agents}
        by_split[split] = rows
        print()
        print("\n".join(table(rows, f"Table VII, split {split} ({args.per_family} per family"
                              f"{' per split' if split == 'all' else ''})")))
    print("\nCalibration checks:")
    for what, ok in checks(by_split):
        print(f"  {'ok  ' if ok else 'FAIL'} {what}")
    episodes = {a: {(t[1], t[3]): (f"family {t[3] % 5}", 100 * r["score"]["total"])
                    for t, r in results if t[0] == a and r["status"] == "completed"}
                for a in agents}
    order = [a for a in PAPER]  # Table VII's order, lowest Avg first
    print("\n".join(uncertainty_lines(episodes, order, {s: 1.0 for s in splits}, LABELS)))
    spread = paired_spread(episodes, order)
    if spread:
        print("  paired spread, rms over neighbours (Track2.reference_spread): "
              + ", ".join(f"{s} {v:.1f}" for s, v in spread.items()))
    if failed:
        print(f"\n{len(failed)} episodes did not complete: {failed[:10]}")
    if args.json is not None:
        args.json.write_text(json.dumps([{"agent": t[0], "split": t[1], "seed": t[2],
                                          "index": t[3], "result": r} for t, r in results]))
    print(f"\nload average at the end {load_average()}; total {time.monotonic() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
