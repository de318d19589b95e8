"""Track 2 episodes with every baseline in a real container under the full sandbox.

A short episode each (one attempt of a rotation, at most 250 steps): what is checked is
that the image builds offline, runs on numpy alone, reads its packet from the read-only
``/input``, plays through the three stages and leaves valid files — not how well it does
(that is the calibration benchmark's job).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from _support import RecordingRuntime  # tests/orchestrator/_support.py
from mcap.reader import make_reader

from orchestrator._episode.worker import EpisodeSpec, run_episode
from schemas import EpisodeResult, EpisodeStatus, Limits

pytestmark = [pytest.mark.docker]

# Official clock (never binding here); one attempt keeps every episode short.
LIMITS = Limits(startup_s=60.0)
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
NAMES = ("waypoint", "demoparser", "imitation", "trajectory", "taskmodel")


@pytest.fixture(scope="module")
def track2_images(docker_engine: Any) -> dict[str, str]:
    """The agent base and the Track 2 baselines, built offline (only what is needed here, so
    that another example's build does not hold these tests back). The task-model image is
    built FROM the demo parser's: its hash covers that one's, so it is rebuilt with it."""
    from orchestrator._images.build import build_agent_base, build_folder

    build_agent_base(docker_engine, say=lambda m: None)
    return {name: build_folder(docker_engine, EXAMPLES / f"track2_{name}",
                               f"eagc/track2-{name}:latest", say=lambda m: None)
            for name in NAMES}


def _run(engine: Any, runs: Path, image: str, seed: int, index: int
         ) -> tuple[EpisodeResult, RecordingRuntime]:
    runtime = RecordingRuntime(engine)
    spec = EpisodeSpec(track="track2", image=image, seed=seed, split="standard", index=index,
                       params={"demo_frames": False, "max_attempts": 1}, limits=LIMITS,
                       runs_dir=runs,
                       exit_grace_s=5.0)
    return run_episode(spec, runtime), runtime


def _events(result: EpisodeResult) -> list[dict[str, Any]]:
    with open(result.mcap or "", "rb") as f:
        return [json.loads(m.data) for _, c, m in make_reader(f).iter_messages()
                if c.topic == "/eagc/event"]


# The host releases its rendering context when it stops serving: closing the episode's
# renderer from another thread raised EGL_BAD_ACCESS in its destructor before.
@pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")
@pytest.mark.parametrize("name", NAMES)
def test_baseline_plays_in_a_container(
    name: str, docker_engine: Any, track2_images: dict[str, str], runs_dir: Path
) -> None:
    result, runtime = _run(docker_engine, runs_dir, track2_images[name], seed=4201, index=1)
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    assert result.runtime == "docker"
    assert result.stages_reached == ("demonstration", "parsing", "execution")
    assert {f.name for f in result.files if f.ok} == {"task_model.json", "episode_log.jsonl"}
    assert result.stats.steps >= 1
    ends = [e for e in _events(result) if e["event"] == "attempt_end"]
    assert ends and ends[0]["index"] == 1
    (attrs,) = runtime.inspected
    mounts = {m["Destination"]: m for m in attrs["Mounts"]}
    assert set(mounts) == {"/run/eagc", "/output", "/input"}
    assert mounts["/input"]["RW"] is False
    assert attrs["Config"]["Env"].count("EAGC_INPUT=/input") == 1
    out = Path(result.episode_dir or "") / "host" / "output"
    log = [json.loads(line) for line in (out / "episode_log.jsonl").read_text().splitlines()]
    assert any(r["event"] == "plan" for r in log), "it read the demonstration packet"
