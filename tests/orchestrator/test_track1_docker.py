"""Track 1's baselines in their containers, built offline, under the full sandbox, with
scaled budgets and step caps: the heuristic map planner for a whole episode
(files, MCAP log, plan, picture), every other baseline (and the symbolic agent on the
public skills) for a short one, and the learned-vision baseline on the vision split."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._runtimes.docker import DockerRuntime
from plugins import load_track
from schemas import (
    EpisodeResult,
    EpisodeStatus,
    Limits,
    LogRecord,
    WorldModel,
    parse_json,
    parse_jsonl,
)

pytestmark = [pytest.mark.docker]


def test_heuristic_track1_episode_in_its_container(docker_engine: Any, images: dict,
                                                   runs_dir: Path) -> None:
    assert "eagc/track1-heuristic:latest" in images
    spec = EpisodeSpec(track="track1", image="eagc/track1-heuristic:latest", seed=1001,
                       split="standard", runs_dir=runs_dir, exit_grace_s=10.0,
                       limits=Limits(time_scale=0.1, max_steps_per_stage=150, memory_mb=1024))
    result = run_episode(spec, DockerRuntime(docker_engine))
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    assert result.runtime == "docker" and result.container is not None
    assert result.stages_reached == ("exploration", "planning", "execution")
    card = result.score
    assert card.metrics["model_verification"] > 0.2, card
    assert result.stats.latency_ms_median is not None and result.stats.peak_memory_bytes

    host = Path(result.episode_dir or "") / "host"
    model = parse_json((host / "output" / "world_model.json").read_bytes(), WorldModel,
                       source="world_model.json")
    assert model.rooms and model.connections and model.objects
    log = parse_jsonl((host / "output" / "episode_log.jsonl").read_bytes(), source="log")
    assert all(isinstance(r, LogRecord) for r in log) and any(r.event == "plan" for r in log)
    assert (host / "snapshots" / "exploration" / "world_model.json").is_file()

    topics: dict[str, int] = {}
    plan_sent = False
    with open(host / "episode.mcap", "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            topics[channel.topic] = topics.get(channel.topic, 0) + 1
            if channel.topic == "/eagc/request":
                body = json.loads(message.data)
                plan_sent |= body.get("kind") == "end_stage" and "plan" in body.get("payload", {})
    for topic in ("/eagc/scenario", "/eagc/observation", "/eagc/event", "/eagc/score",
                  "/eagc/file/exploration/world_model.json"):
        assert topics.get(topic), f"MCAP has no {topic}: {sorted(topics)}"
    assert plan_sent, "the plan did not travel in the end_stage payload"
    picture = load_track("track1").picture(Path(result.episode_dir or ""))
    assert picture.stat().st_size > 1000

    left = docker_engine.containers.list(
        all=True, filters={"label": f"eagc.episode={result.episode}"})
    assert left == [], "the episode's container is still there"


def _short_episode(docker_engine: Any, image: str, split: str, seed: int,
                   runs_dir: Path) -> EpisodeResult:
    """A short episode (40 steps a stage, a tenth of the time) of an image in its container,
    which completes every stage and leaves both files."""
    spec = EpisodeSpec(track="track1", image=image, seed=seed, split=split,
                       runs_dir=runs_dir, exit_grace_s=10.0,
                       limits=Limits(time_scale=0.1, max_steps_per_stage=40, memory_mb=1024))
    result = run_episode(spec, DockerRuntime(docker_engine))
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    assert result.stages_reached == ("exploration", "planning", "execution")
    assert {f.name for f in result.files if f.ok} == {"world_model.json", "episode_log.jsonl"}
    assert result.stats.steps > 0
    return result


@pytest.mark.parametrize("name", ["sanity", "memoryfree", "lookahead", "structured", "symbolic"])
def test_every_other_baseline_runs_in_its_container(docker_engine: Any, images: dict,
                                                    runs_dir: Path, name: str) -> None:
    image = f"eagc/track1-{name}:latest"
    assert image in images
    result = _short_episode(docker_engine, image, "challenge", 1002, runs_dir)
    host = Path(result.episode_dir or "") / "host"
    assert (host / "snapshots" / "exploration" / "world_model.json").is_file()
    if name != "sanity":  # the random agent maps nothing; every other one maps as it goes
        model = parse_json((host / "output" / "world_model.json").read_bytes(), WorldModel,
                           source="world_model.json")
        assert model.rooms, "an empty world model"
        assert result.score.metrics["model_verification"] > 0.1, result.score.metrics


def test_the_learned_vision_baseline_plays_the_vision_split_in_its_container(
        docker_engine: Any, images: dict, runs_dir: Path) -> None:
    """The vision split's baseline (examples/track1_vision, built FROM the structured
    planner's image): pixels in, its detector's findings under ids of its own, actions by
    pixel; what it maps is matched to the truth by position, and it finds real things."""
    image = "eagc/track1-vision:latest"
    assert image in images
    result = _short_episode(docker_engine, image, "vision", 1003, runs_dir)
    host = Path(result.episode_dir or "") / "host"
    model = parse_json((host / "output" / "world_model.json").read_bytes(), WorldModel,
                       source="world_model.json")
    assert model.rooms and (model.objects or model.containers), "the detector found nothing"
    assert result.score.metrics["model_verification"] > 0.1, result.score.metrics
    assert result.stats.latency_ms_median is not None and result.stats.peak_memory_bytes
