"""Campaign orchestration benchmark: overhead per episode and throughput, 1 and 2 workers,
beside a naive sequential loop of the same episodes (same seeds) in the same run.

The agent (tests/containers/waiting) mostly waits, so two workers on two cores measure the
orchestrator rather than CPU contention. Episode length is set by the step cap (0.1 s per
step, two stages). Per episode, from each episode's own MCAP log:

- startup: run_episode start → the first observation (scenario, sim host, container start,
  the agent's hello and reset);
- teardown: the last reply → the result (container stop and removal, /output collection,
  scoring, files);
- commit: the SQLite commit of the result;
- dispatch: campaign wall time per episode (1 worker) minus the naive loop's, i.e. what Ray,
  the store and the driver add on top of run_episode.

Run:  python tests/benchmarks/bench_campaign.py [--episodes 4] [--episode-s 30]
Goal (issue 3): overhead under 1.5 s per episode; scaling efficiency ≥ 90 % for ≥ 30 s.
"""

from __future__ import annotations

import argparse
import json
import logging
import statistics
import tempfile
import time
from pathlib import Path

from mcap.reader import make_reader

REPO = Path(__file__).resolve().parents[2]
STEP_S = 0.1  # the waiting agent's pause per step


def _marks(result) -> dict[str, float]:  # noqa: ANN001
    """Times of an episode from its MCAP (seconds): host open, hello, first obs, last reply."""
    marks: dict[str, float] = {}
    with open(result.mcap, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            t = message.log_time / 1e9
            marks.setdefault("open", t)
            if channel.topic == "/eagc/request" and "hello" not in marks:
                marks["hello"] = t
            if channel.topic == "/eagc/reply":
                if "first_obs" not in marks and json.loads(message.data).get("kind") == \
                        "observation":
                    marks["first_obs"] = t
                marks["last_reply"] = t
    assert {"hello", "first_obs", "last_reply"} <= set(marks), result.mcap
    return marks


def _breakdown(results) -> dict[str, float]:  # noqa: ANN001
    parts: dict[str, list[float]] = {k: [] for k in ("prep", "boot", "handshake", "startup",
                                                     "teardown", "active", "gap")}
    for r in results:
        m = _marks(r)
        parts["prep"].append(m["open"] - r.started_at)
        parts["boot"].append(m["hello"] - m["open"])
        parts["handshake"].append(m["first_obs"] - m["hello"])
        parts["startup"].append(m["first_obs"] - r.started_at)
        parts["teardown"].append(r.finished_at - m["last_reply"])
        parts["active"].append(m["last_reply"] - m["first_obs"])
    ordered = sorted(results, key=lambda r: r.started_at)
    # One worker: the time from one episode's end to the next one's start (dispatch).
    parts["gap"] = [b.started_at - a.finished_at
                    for a, b in zip(ordered, ordered[1:], strict=False)] or [0.0]
    return {k: statistics.mean(v) for k, v in parts.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=4)
    parser.add_argument("--episode-s", type=float, default=30.0,
                        help="approximate episode length (the agent waits)")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)

    import ray

    from orchestrator._campaign.driver import run_campaign
    from orchestrator._campaign.driver_io import CampaignOptions
    from orchestrator._campaign.seeds import load_secret, seed_list
    from orchestrator._campaign.spec import store_path
    from orchestrator._episode.worker import EpisodeSpec, run_episode
    from orchestrator._images.build import build_agent_base, build_folder
    from orchestrator._results.store import ResultsStore
    from orchestrator._runtimes.docker import DockerRuntime, docker_client
    from schemas import CampaignSpec, Limits, Split, Submission

    client = docker_client()
    build_agent_base(client, lambda m: None)
    image = build_folder(client, REPO / "tests" / "containers" / "waiting",
                         "eagc-test/waiting:latest", lambda m: None)
    steps = max(1, round(args.episode_s / (2 * STEP_S)))
    limits = Limits(memory_mb=256, max_steps_per_stage=steps)
    root = Path(tempfile.mkdtemp(prefix="eagc-bc-", dir="/tmp"))
    spec = CampaignSpec(name="bench", track="sanity", phase="local",
                        splits=(Split(name="standard", episodes=args.episodes),),
                        submissions=(Submission(team="waiting", image=image),),
                        limits=limits, output=root / "naive")
    seeds = seed_list(spec, load_secret(spec))
    print(f"{args.episodes} episodes of ~{2 * steps * STEP_S:.0f} s (waiting agent, "
          f"{steps} steps per stage), results in {root}")

    runtime = DockerRuntime(client)
    t = time.perf_counter()
    naive = [run_episode(EpisodeSpec(track="sanity", image=image, seed=s.seed,
                                     split="standard", limits=limits,
                                     runs_dir=root / "naive"), runtime) for s in seeds]
    naive_wall = time.perf_counter() - t
    rows = [("naive loop", 1, naive_wall, None, _breakdown(naive), None, naive)]

    for workers in (1, 2):
        run_spec = spec.model_copy(update={"output": root / f"w{workers}"})
        t = time.perf_counter()
        ray.init(num_cpus=2, resources={"eagc_slot": float(workers)},
                 include_dashboard=False, log_to_driver=False, logging_level=logging.WARNING)
        ray_start = time.perf_counter() - t
        try:
            t = time.perf_counter()
            report = run_campaign(run_spec, CampaignOptions(workers=workers, progress=False))
            wall = time.perf_counter() - t
        finally:
            ray.shutdown()
        assert report.committed == args.episodes, report
        with ResultsStore(store_path(run_spec)) as store:
            results = [e.result for e in store.results(spec.name)]
        rows.append((f"campaign, {workers} worker{'s' * (workers > 1)}", workers, wall,
                     ray_start, _breakdown(results), statistics.mean(report.commit_s), results))

    n = args.episodes
    t1 = rows[1][2]
    print()
    print(f"{'':22} {'wall s':>7} {'ep/min':>7} {'Ray start':>9} {'startup':>8} "
          f"{'teardown':>9} {'commit':>8} {'gap':>7} {'scaling':>8}")
    for name, workers, wall, ray_start, b, commit, _ in rows:
        gap = f"{b['gap']:.2f}s" if workers == 1 and not name.startswith("naive") else ""
        scaling = "" if workers == 1 else f"{100 * t1 / (workers * wall):.0f} %"
        print(f"{name:22} {wall:7.1f} {60 * n / wall:7.2f} "
              f"{'' if ray_start is None else f'{ray_start:.1f} s':>9} "
              f"{b['startup']:7.2f}s {b['teardown']:8.2f}s "
              f"{'' if commit is None else f'{1000 * commit:.1f}ms':>8} {gap:>7} {scaling:>8}")
    b, commit = rows[1][4], rows[1][5]
    fixed = t1 - sum(r.stats.wall_s for r in rows[1][6]) - b["gap"] * (n - 1)
    print(f"\nstartup = scenario and sim host {b['prep']:.2f} s + container start and agent "
          f"boot to hello {b['boot']:.2f} s + hello to first observation "
          f"{b['handshake']:.2f} s")
    print(f"per-episode overhead, 1 worker: startup {b['startup']:.2f} s + teardown "
          f"{b['teardown']:.2f} s + dispatch gap {b['gap']:.2f} s + commit "
          f"{1000 * commit:.1f} ms = {b['startup'] + b['teardown'] + b['gap'] + commit:.2f} s"
          f" (of which the campaign adds {b['gap'] + commit:.2f} s over run_episode)")
    print(f"campaign fixed cost (board actor, label cleanup, first task's imports): "
          f"{fixed:.1f} s; active agent time per episode {b['active']:.1f} s")


if __name__ == "__main__":
    main()
