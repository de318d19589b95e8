"""The three Track 1 baselines over a fixed list of seeds, as local processes through the real
episode worker (SimHost over Zenoh, MCAP, /output collection, scoring), with step caps so the
outcome does not depend on the machine's speed. They must order as in the paper's Table IV:
the sanity baseline far below both others, the heuristic map planner above the memory-free
policy on model verification and recovery; the heuristic completes most standard episodes.

The agents run WITHOUT the sandbox (``LocalProcessRuntime``, development only); the same
heuristic agent runs in its container in ``tests/orchestrator/test_track1_docker.py``.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from orchestrator._local import LocalProcessRuntime
from orchestrator._worker import EpisodeSpec, run_episode
from plugins import load_track
from schemas import EpisodeResult, EpisodeStatus, Limits

pytestmark = [pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
STANDARD = list(range(1000, 1020))
CHALLENGE = list(range(1000, 1003))
LIMITS = Limits(max_steps_per_stage=400, time_scale=0.1, startup_s=60.0)
AGENTS = ("track1_sanity", "track1_memoryfree", "track1_heuristic")


def _run(agent: str, split: str, seed: int, runs: Path) -> EpisodeResult:
    spec = EpisodeSpec(track="track1", image=f"python {ROOT / 'examples' / agent / 'agent.py'}",
                       seed=seed, split=split, limits=LIMITS, runs_dir=runs, exit_grace_s=10.0)
    return run_episode(spec, LocalProcessRuntime(quiet=True))


@pytest.fixture(scope="module")
def results() -> Iterator[dict[str, list[EpisodeResult]]]:
    # A short folder: unix socket paths are limited to 108 bytes.
    runs = Path(tempfile.mkdtemp(prefix="t1b-", dir="/tmp"))
    jobs = [(a, split, s) for a in AGENTS
            for split, seeds in (("standard", STANDARD), ("challenge", CHALLENGE))
            for s in seeds]
    # Two at a time: an agent process and its host thread take turns, so two episodes share
    # two cores well.
    with ThreadPoolExecutor(max_workers=int(os.environ.get("EAGC_TEST_WORKERS", "2"))) as pool:
        done = list(pool.map(lambda job: _run(*job, runs), jobs))
    out: dict[str, list[EpisodeResult]] = {a: [] for a in AGENTS}
    for (agent, _, _), r in zip(jobs, done, strict=True):
        out[agent].append(r)
    yield out
    shutil.rmtree(runs, ignore_errors=True)


def test_every_episode_ran_to_its_end(results: dict[str, list[EpisodeResult]]) -> None:
    for agent, rs in results.items():
        bad = [(r.split, r.status.value, r.failure and r.failure.message) for r in rs
               if r.status is not EpisodeStatus.COMPLETED]
        assert not bad, f"{agent}: {bad}"
        for r in rs:
            assert r.stages_reached == ("exploration", "planning", "execution")
            assert {f.name for f in r.files if f.ok} == {"world_model.json", "episode_log.jsonl"}


def test_baselines_order_as_in_table_iv(results: dict[str, list[EpisodeResult]]) -> None:
    plugin = load_track("track1")
    rows = {agent: plugin.summarize(rs) for agent, rs in results.items()}
    keys = ("standard", "challenge", "final", "task_success", "model_verification", "recovery",
            "invalid_actions")
    print("\nTrack 1 baselines (Table IV layout, local processes, step cap 400):")
    print(f"{'system':20s}" + "".join(f"{k[:12]:>14s}" for k in keys))
    for agent, row in rows.items():
        print(f"{agent:20s}" + "".join(f"{row[k] or 0.0:14.1f}" for k in keys))
    sanity, memoryfree, heuristic = (rows[a] for a in AGENTS)
    assert sanity["final"] < 0.5 * min(memoryfree["final"], heuristic["final"])
    assert heuristic["model_verification"] > memoryfree["model_verification"] + 20
    assert heuristic["recovery"] > memoryfree["recovery"] + 20
    assert memoryfree["model_verification"] > sanity["model_verification"]
    assert sanity["task_success"] <= 5.0
    standard = [r for r in results["track1_heuristic"] if r.split == "standard"]
    done = sum(r.score.metrics["task_success"] for r in standard)
    assert done >= 0.75 * len(standard), f"heuristic completed {done}/{len(standard)}"
