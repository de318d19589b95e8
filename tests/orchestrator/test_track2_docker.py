"""Track 2 episodes with the baseline agents in real containers under the full sandbox."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from _support import RecordingRuntime  # tests/orchestrator/_support.py
from mcap.reader import make_reader

from orchestrator._worker import EpisodeSpec, run_episode
from plugins.track2 import attempt_png
from schemas import EpisodeResult, EpisodeStatus, Limits

pytestmark = [pytest.mark.docker]

# Scaled clock (never binding here) and step caps: outcomes do not depend on the machine.
LIMITS = Limits(time_scale=0.1, max_steps_per_stage=2000, startup_s=60.0)
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def track2_images(docker_engine: Any) -> dict[str, str]:
    """The agent base and the two Track 2 baselines, built offline (only what is needed here,
    so that another example's build does not hold these tests back)."""
    from orchestrator._images import build_agent_base, build_folder

    build_agent_base(docker_engine, say=lambda m: None)
    return {name: build_folder(docker_engine, EXAMPLES / f"track2_{name}",
                               f"eagc/track2-{name}:latest", say=lambda m: None)
            for name in ("waypoint", "demoparser")}


def _run(engine: Any, runs: Path, image: str, seed: int) -> tuple[EpisodeResult, RecordingRuntime]:
    runtime = RecordingRuntime(engine)
    spec = EpisodeSpec(track="track2", image=image, seed=seed, split="standard", limits=LIMITS,
                       runs_dir=runs, exit_grace_s=5.0)
    return run_episode(spec, runtime), runtime


def _events(result: EpisodeResult) -> list[dict[str, Any]]:
    with open(result.mcap or "", "rb") as f:
        return [json.loads(m.data) for _, c, m in make_reader(f).iter_messages()
                if c.topic == "/eagc/event"]


def test_waypoint_agent_uses_three_attempts_in_a_container(
    docker_engine: Any, track2_images: dict[str, str], runs_dir: Path
) -> None:
    # Seed 1: a rotation whose goal angle differs from the demonstration's; replaying the
    # demonstrated turn fails, so every attempt is used and each is reset and reported.
    result, runtime = _run(docker_engine, runs_dir, track2_images["waypoint"], seed=1)
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    assert result.runtime == "docker"
    assert result.stages_reached == ("demonstration", "parsing", "execution")
    assert {f.name for f in result.files if f.ok} == {"task_model.json", "episode_log.jsonl"}
    assert result.score.metrics["task_success"] == 0.0 and result.score.metrics["attempts"] == 3

    ends = [e for e in _events(result) if e["event"] == "attempt_end"]
    assert [e["index"] for e in ends] == [1, 2, 3] and not any(e["success"] for e in ends)
    (last,) = [e for e in _events(result) if e["event"] == "episode_end"]
    assert last["reason"] == "attempts_used"

    out = Path(result.episode_dir or "") / "host" / "output"
    log = [json.loads(line) for line in (out / "episode_log.jsonl").read_text().splitlines()]
    heard = [r["data"] for r in log if r["event"] == "attempt" and "success" in r["data"]]
    assert [h["attempt"] for h in heard] == [1, 2, 3], "the agent heard every attempt's outcome"
    assert any(r["event"] == "plan" for r in log), "it read the demonstration packet"

    (attrs,) = runtime.inspected
    mounts = {m["Destination"]: m for m in attrs["Mounts"]}
    assert set(mounts) == {"/run/eagc", "/output", "/input"}
    assert mounts["/input"]["RW"] is False
    assert attrs["Config"]["Env"].count("EAGC_INPUT=/input") == 1
    png = attempt_png(result.episode_dir or "")
    assert png.name == "attempt_3.png" and png.read_bytes()[:4] == b"\x89PNG"


def test_demo_parser_agent_succeeds_in_a_container(
    docker_engine: Any, track2_images: dict[str, str], runs_dir: Path
) -> None:
    result, _ = _run(docker_engine, runs_dir, track2_images["demoparser"], seed=1)
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    assert result.score.metrics["task_success"] == 1.0
    assert result.score.metrics["attempts"] == 1.0
    assert result.score.metrics["task_model"] > 0.9
