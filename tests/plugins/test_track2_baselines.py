"""Track 2 baselines as local processes through the real worker, host and Zenoh.

The agents run with ``LocalProcessRuntime`` (no sandbox: development only; the Docker test is
``tests/orchestrator/test_track2_docker.py``). Budgets are step-capped so that outcomes do
not depend on the machine: each attempt has its family's step cap, the execution stage a
cap above three attempts, and the clock is scaled but never binding.
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from orchestrator._local import LocalProcessRuntime
from orchestrator._worker import EpisodeSpec, run_episode
from plugins import load_track
from plugins.track2 import attempt_png
from schemas import EpisodeResult, EpisodeStatus, Limits, TaskModel, load_json

TRACK = load_track("track2")
LIMITS = Limits(time_scale=0.2, max_steps_per_stage=2000, startup_s=60.0)
# 20 instances: every family 4 times, half of them from the challenge split.
INSTANCES = [(seed, "standard" if seed < 10 else "challenge") for seed in range(20)]
AGENTS = {"waypoint": "track2_waypoint", "demo parser": "track2_demoparser"}


@pytest.fixture(scope="module")
def runs() -> Iterator[Path]:
    # Short on purpose: unix socket paths are limited to 108 bytes.
    folder = Path(tempfile.mkdtemp(prefix="eagc-t2-", dir="/tmp"))
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def run(agent: str, seed: int, split: str, runs: Path) -> EpisodeResult:
    spec = EpisodeSpec(track="track2", image=f"python examples/{agent}/agent.py", seed=seed,
                       split=split, params={"demo_frames": False}, limits=LIMITS,
                       runs_dir=runs, exit_grace_s=5.0)
    return run_episode(spec, LocalProcessRuntime(quiet=True))


def test_demo_parser_episode_end_to_end(runs: Path) -> None:
    r = run("track2_demoparser", 3, "standard", runs)
    assert r.status is EpisodeStatus.COMPLETED, r.failure
    assert r.stages_reached == ("demonstration", "parsing", "execution")
    assert {f.name for f in r.files if f.ok} == {"task_model.json", "episode_log.jsonl"}
    assert r.score.metrics["task_success"] == 1.0 and r.score.total > 0.8
    assert r.score.metrics["task_model"] > 0.9
    host = Path(r.episode_dir or "") / "host"
    model = load_json(host / "output" / "task_model.json", TaskModel)
    assert model.family == "opening"
    assert (host / "snapshots" / "parsing" / "task_model.json").is_file()
    png = attempt_png(r.episode_dir or "")
    assert png == host / "attempt_1.png" and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_waypoint_replay_uses_all_three_attempts(runs: Path) -> None:
    r = run("track2_waypoint", 1, "standard", runs)  # a rotation whose goal angle moved
    assert r.status is EpisodeStatus.COMPLETED, r.failure
    assert r.score.metrics["task_success"] == 0.0 and r.score.metrics["attempts"] == 3.0
    assert "attempts=3, success at none" in r.score.notes
    log = (Path(r.episode_dir or "") / "host" / "output" / "episode_log.jsonl").read_text()
    assert log.count('"attempts_left"') == 3, "the agent heard the outcome of every attempt"
    png = attempt_png(r.episode_dir or "", attempt=2)
    assert png.name == "attempt_2.png" and png.stat().st_size > 1000


@pytest.mark.slow
def test_demo_parser_beats_waypoint_replay(runs: Path) -> None:
    results = {name: [run(agent, seed, split, runs) for seed, split in INSTANCES]
               for name, agent in AGENTS.items()}
    for name, rs in results.items():
        bad = [(r.episode, r.status.value) for r in rs if r.status is not EpisodeStatus.COMPLETED]
        assert not bad, f"{name}: {bad}"
    rows = {name: TRACK.summarize(rs) for name, rs in results.items()}
    print()
    print(f"{'baseline':12s}" + "".join(f"{c.title:>16s}" for c in TRACK.columns))
    for name, row in rows.items():
        cells = ["-" if row[c.key] is None else c.fmt.format(row[c.key]) for c in TRACK.columns]
        print(f"{name:12s}" + "".join(f"{x:>16s}" for x in cells))
    wp, dp = rows["waypoint"], rows["demo parser"]
    assert dp["final"] > wp["final"] + 10  # type: ignore[operator]
    for fam in ("insertion", "rotation", "assembly", "opening", "tool_use"):
        assert dp[fam] > wp[fam], fam  # type: ignore[operator]
    assert dp["task_success"] > wp["task_success"]  # type: ignore[operator]
    assert dp["task_model"] > wp["task_model"] + 30  # type: ignore[operator]
    assert dp["attempts"] < wp["attempts"]  # type: ignore[operator]
