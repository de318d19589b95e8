"""Soak benchmark: a long campaign of short episodes, watched for anything that grows.

One real driver process (``python -m orchestrator.cli.campaign run``) on its own embedded
Ray with two container slots runs ``--episodes`` short Docker episodes (the waiting test
agent, ``--steps`` steps of 0.1 s in each of the two sanity stages). Every few seconds the
benchmark samples, beside the number of committed episodes:

- the driver's RSS, open fds and threads;
- the Ray processes' (GCS, raylet, workers, …) summed RSS, fds and threads;
- eagc containers of the campaign (running or not), eagc output mounts;
- files in the driver's private TMPDIR and in its Ray temp dir (less the logs), and the
  bytes of Ray's logs.

It prints each one's growth per 100 episodes (least-squares slope over the samples after
the first 10 % of the episodes, the warm-up) and the null-episode overhead: wall time per
episode per slot, less the agent's own time. What each episode keeps on purpose (its
folder, with MCAP and result) is printed apart, per episode.

Run:  python tests/benchmarks/bench_soak.py [--episodes 1000] [--steps 1]
"""

from __future__ import annotations

import argparse
import os
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "orchestrator"))
from _machine import load_average, machine_line  # noqa: E402
from test_campaign_helpers import processes_mentioning  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
STEP_S = 0.1


def _proc(pid: int) -> tuple[int, int, int]:
    """(rss bytes, fds, threads) of a process; zeros if it is gone."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
        rss = next(int(x.split()[1]) * 1024 for x in status.splitlines()
                   if x.startswith("VmRSS:"))
        threads = next(int(x.split()[1]) for x in status.splitlines()
                       if x.startswith("Threads:"))
        fds = len(os.listdir(f"/proc/{pid}/fd"))
        return rss, fds, threads
    except (OSError, StopIteration, ValueError):
        return 0, 0, 0


def _files(folder: Path, skip: str | None = None) -> tuple[int, int]:
    """(files, bytes) under ``folder``, leaving out paths containing ``skip``."""
    n = size = 0
    for root, _, names in os.walk(folder):
        if skip and skip in root:
            continue
        for name in names:
            try:
                size += os.lstat(os.path.join(root, name)).st_size
                n += 1
            except OSError:
                pass
    return n, size


def _logs(folder: Path) -> int:
    # Each session once (session_latest is a link to the newest).
    return sum(_files(p)[1] for p in folder.glob("**/session_*/logs")
               if not p.parent.is_symlink())


def _committed(store: Path, name: str) -> int:
    if not store.exists():
        return 0
    db = sqlite3.connect(f"file:{store}?mode=ro", uri=True, timeout=10)
    try:
        return int(db.execute("SELECT COUNT(*) FROM episodes WHERE campaign=?",
                              (name,)).fetchone()[0])
    except sqlite3.OperationalError:
        return 0
    finally:
        db.close()


def _containers(name: str) -> int:
    r = subprocess.run(["docker", "ps", "-aq", "--filter", f"label=eagc.campaign={name}"],
                       capture_output=True, text=True)
    return len(r.stdout.split())


def _mounts(folder: Path) -> int:
    return sum(1 for line in Path("/proc/self/mounts").read_text().splitlines()
               if line.startswith("eagc-output ") and str(folder) in line)


def _slope(xs: list[float], ys: list[float]) -> float:
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    den = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) / den if den else 0.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=1000)
    ap.add_argument("--steps", type=int, default=1, help="steps per stage (0.1 s each)")
    ap.add_argument("--every", type=float, default=5.0, help="seconds between samples")
    args = ap.parse_args()
    from orchestrator._images.build import build_agent_base, build_folder
    from orchestrator._runtimes.docker import docker_client

    engine = docker_client()
    build_agent_base(engine, lambda m: None)
    build_folder(engine, REPO / "tests" / "containers" / "waiting", "eagc-test/waiting:latest",
                 lambda m: None)

    work = Path(tempfile.mkdtemp(prefix="eagc-soak-", dir="/tmp"))
    ray_tmp, tmp = work / "ray", work / "tmp"
    ray_tmp.mkdir()
    tmp.mkdir()
    name = "soak"
    doc = {"name": name, "track": "sanity", "phase": "local",
           "splits": [{"name": "standard", "episodes": args.episodes}],
           "submissions": [{"team": "waiting", "image": "eagc-test/waiting:latest"}],
           "limits": {"memory_mb": 256, "max_steps_per_stage": args.steps, "startup_s": 60},
           "retries": 2, "output": str(work / "out")}
    campaign = work / "soak.yaml"
    campaign.write_text(yaml.safe_dump(doc))
    env = {**os.environ, "RAY_TMPDIR": str(ray_tmp), "TMPDIR": str(tmp),
           "RAY_USAGE_STATS_ENABLED": "0", "PYTHONPATH": str(REPO), "MUJOCO_GL": "egl"}
    print(machine_line("ray", "docker", extra=f"load average {load_average()}"))
    print(f"{args.episodes} episodes, 2 slots, {args.steps} step(s) of {STEP_S} s per stage")
    started = time.time()
    driver = subprocess.Popen(
        [sys.executable, "-m", "orchestrator.cli.campaign", "run", str(campaign),
         "--workers", "2", "--no-progress"], env=env, cwd=REPO,
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    samples: list[dict[str, float]] = []
    store = work / "out" / "results.sqlite"
    while driver.poll() is None:
        time.sleep(args.every)
        ray = processes_mentioning(str(ray_tmp)) - {driver.pid}
        d = _proc(driver.pid)
        w = [_proc(p) for p in ray]
        samples.append({
            "episodes": _committed(store, name), "t": time.time() - started,
            "driver_rss_mb": d[0] / 2**20, "driver_fds": d[1], "driver_threads": d[2],
            "ray_rss_mb": sum(x[0] for x in w) / 2**20, "ray_fds": sum(x[1] for x in w),
            "ray_threads": sum(x[2] for x in w), "ray_processes": len(w),
            "containers": _containers(name), "mounts": _mounts(work),
            "temp_files": _files(tmp)[0] + _files(ray_tmp, skip="/logs")[0],
            "ray_logs_mb": _logs(ray_tmp) / 2**20,
        })
    wall = time.time() - started
    err = driver.stderr.read() if driver.stderr else ""
    done = _committed(store, name)
    print(f"driver exit code {driver.returncode}; {done} episodes committed in {wall:.0f} s")
    if driver.returncode != 0:
        print(err[-2000:])
    # After the warm-up, and only while the driver still ran (its RSS read as 0 after).
    warm = [s for s in samples if s["episodes"] >= 0.1 * args.episodes and s["driver_rss_mb"]]
    if len(warm) >= 3:
        xs = [s["episodes"] for s in warm]
        print(f"\n{'growth per 100 episodes':<26}{'per 100':>12}{'first':>10}{'last':>10}")
        for key in ("driver_rss_mb", "driver_fds", "driver_threads", "ray_rss_mb", "ray_fds",
                    "ray_threads", "ray_processes", "containers", "mounts", "temp_files",
                    "ray_logs_mb"):
            ys = [s[key] for s in warm]
            print(f"{key:<26}{100 * _slope(xs, ys):>12.2f}{ys[0]:>10.1f}{ys[-1]:>10.1f}")
    agent_s = 2 * args.steps * STEP_S
    per_slot = wall * 2 / max(done, 1)
    print(f"\nnull-episode overhead: {per_slot - agent_s:.2f} s per episode per slot "
          f"({per_slot:.2f} s wall per episode per slot, {agent_s:.1f} s of it the agent's)")
    n, size = _files(work / "out" / name)
    print(f"kept on purpose: {size / max(done, 1) / 1024:.0f} kB in {n / max(done, 1):.1f} "
          "files per episode (its folder: MCAP, result, snapshots)")
    left = _containers(name), _mounts(work)
    print(f"after the campaign: {left[0]} container(s), {left[1]} mount(s) left")
    print(f"load average after: {load_average()}")
    subprocess.run(["rm", "-rf", str(work)], check=False)


if __name__ == "__main__":
    main()
