"""``simhost.client.GymEnv``: a policy written against the offline gymnasium environment runs
unchanged against the real sim host.

The policies and the agent are in ``_gym_agent.py``. The episodes run through the episode
worker (``run_episode``: SimHost over Zenoh, the agent a local process, /output collected and
checked, the score), as in ``tests/orchestrator/test_local_runtime.py``.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import gymnasium
import numpy as np
import pytest
from gymnasium import spaces

from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._runtimes.local import LocalProcessRuntime
from schemas import EpisodeStatus, Limits
from schemas._protocol import FieldSpec, HelloReply, StageInfo
from simhost.client import GymClientError, GymEnv, StageRule
from simhost.client._outputs import OutputFileError

sys.path.insert(0, str(Path(__file__).parent))
from _gym_agent import EXECUTE_STEPS, EXPLORE_STEPS, ArenaPolicy, HousePolicy  # noqa: E402

AGENT = Path(__file__).parent / "_gym_agent.py"
SEED = 5


def _hello(track: str, obs: tuple[FieldSpec, ...], act: tuple[FieldSpec, ...]) -> HelloReply:
    return HelloReply(seq=0, episode="ep-test", track=track, observation_spec=obs,
                      action_spec=act, max_request_bytes=1 << 20, startup_budget_s=60.0,
                      stages=(StageInfo(name="explore", budget_s=60.0),
                              StageInfo(name="think", budget_s=60.0, allows_motion=False)))


def _track1_client(tmp_path: Path) -> tuple[GymEnv, Any]:
    """A GymEnv on the hello reply a Track 1 standard episode sends (no host needed)."""
    from plugins.track1._episode import _action_spec, _observation_spec

    offline = gymnasium.make("eagc/House-v0")
    hello = _hello("track1", _observation_spec(offline.unwrapped), _action_spec())
    return GymEnv(SimpleNamespace(spec=hello), output=tmp_path), offline  # type: ignore[arg-type]


def test_the_spaces_are_the_offline_envs(tmp_path: Path) -> None:
    env, offline = _track1_client(tmp_path)
    assert env.action_space == offline.action_space  # Dict of Discrete(8), Box(2), 256, 256
    ours, theirs = env.observation_space.spaces, offline.observation_space.spaces
    assert list(ours) == list(theirs)
    for name, box in theirs.items():
        assert (ours[name].shape, ours[name].dtype) == (box.shape, box.dtype), name
        assert np.all(ours[name].low <= box.low) and np.all(ours[name].high >= box.high), name
    offline.close()


def test_observations_are_converted_to_the_offline_dtypes_and_json_goes_to_info(
        tmp_path: Path) -> None:
    env, offline = _track1_client(tmp_path)
    obs, info = offline.reset(seed=SEED)
    # What the host sends: int8 entries as uint8 (the wire has no int8), plus JSON entries.
    wire = {k: v.astype(np.uint8) if v.dtype == np.int8 else v for k, v in obs.items()}
    wire.update(detections=info["detections"], room_name="kitchen",
                action_result={"primitive": "reset", "ok": True, "reason": ""})
    converted, extra = env._convert(wire)
    assert offline.observation_space.contains(converted)
    assert all(np.array_equal(converted[k], v) and converted[k].dtype == v.dtype
               for k, v in obs.items())
    assert extra == {"detections": info["detections"], "room_name": "kitchen",
                     "action_result": {"primitive": "reset", "ok": True, "reason": ""}}
    offline.close()


def test_actions_are_sent_as_the_offline_env_reads_them(tmp_path: Path) -> None:
    env, offline = _track1_client(tmp_path)
    wire = env._to_wire({"primitive": np.int64(1), "move": np.array([3.0, -2.0], np.float32),
                         "target": 7, "tool": 0, "value": 0.3})
    assert set(wire) == {"primitive", "move", "target", "tool"}  # unknown fields left out
    assert wire["move"].tolist() == [1.0, -1.0]  # clipped, as the offline env clips
    assert np.isnan(env._to_wire({"move": [np.nan, 0.0]})["move"][0])  # the host refuses NaN
    with pytest.raises(GymClientError, match="mapping"):
        env._to_wire(np.zeros(2))
    offline.close()


def test_a_one_field_action_is_that_fields_space(tmp_path: Path) -> None:
    speed = FieldSpec(name="velocity", dtype="float32", shape=(2,), low=-1.0, high=1.0)
    pos = FieldSpec(name="position", dtype="float32", shape=(2,), low=-2, high=2, tensor=True)
    env = GymEnv(SimpleNamespace(spec=_hello("sanity", (pos,), (speed,))),  # type: ignore[arg-type]
                 output=tmp_path)
    assert env.action_space == spaces.Box(-1.0, 1.0, (2,), np.float32)
    assert env._to_wire(np.array([2.0, 0.5]))["velocity"].tolist() == [1.0, 0.5]
    with pytest.raises(GymClientError, match="did you mean 'explore'"):
        GymEnv(env.remote, stages={"explor": StageRule()})


def test_files_are_checked_before_they_are_written(tmp_path: Path) -> None:
    env, offline = _track1_client(tmp_path)
    env._write("episode_log.jsonl", [{"step": 0, "event": "stage"},
                                     {"step": 2, "event": "note", "data": {"a": 1}}])
    lines = (tmp_path / "episode_log.jsonl").read_text().splitlines()
    assert [json.loads(x)["step"] for x in lines] == [0, 2]
    with pytest.raises(OutputFileError, match="line 2: event"):
        env._write("episode_log.jsonl", [{"step": 0, "event": "stage"}, {"step": 1}])
    with pytest.raises(OutputFileError, match="world_model.json"):
        env._write("world_model.json", {"rooms": "none"})
    env._write("notes.txt", "free text")
    assert (tmp_path / "notes.txt").read_text() == "free text"
    assert not list(tmp_path.glob(".*"))  # no temporary file left behind
    offline.close()


def _runs() -> Path:
    return Path(tempfile.mkdtemp(prefix="eagc-", dir="/tmp"))  # short: socket path limit


def _play(track: str, split: str, seed: int, tmp_path: Path, *flags: str,
          limits: Limits = Limits()) -> tuple[Any, dict[str, Any], dict[str, np.ndarray]]:
    out = tmp_path / f"trace-{track}.npz"
    result = run_episode(
        EpisodeSpec(track=track, image=f"{sys.executable} {AGENT} {track} {out} {' '.join(flags)}",
                    seed=seed, split=split, limits=limits, runs_dir=_runs()),
        LocalProcessRuntime(quiet=True),
    )
    tail = result.container.log_tail if result.container else ""
    assert out.exists(), (result.status, result.failure, tail)
    with np.load(out) as z:
        arrays = {k: z[k] for k in z.files}
    return result, json.loads(str(arrays.pop("trace"))), arrays


def _offline_house(steps: int) -> tuple[list[dict[str, np.ndarray]], list[dict[str, Any]]]:
    """The policy on ``gymnasium.make("eagc/House-v0")``, as it was written for."""
    env = gymnasium.make("eagc/House-v0")
    policy = HousePolicy(seed=0)
    obs, _ = env.reset(seed=SEED)
    seen, actions = [], []
    for _ in range(steps):
        assert env.observation_space.contains(obs)
        action = policy(obs)
        assert env.action_space.contains(action)
        seen.append(obs)
        actions.append(action)
        obs, *_ = env.step(action)
    env.close()
    return seen, actions


@pytest.mark.slow
def test_a_policy_written_for_the_offline_house_plays_an_episode_unchanged(
        tmp_path: Path) -> None:
    offline_obs, offline_actions = _offline_house(EXPLORE_STEPS)
    result, trace, arrays = _play("track1", "standard", SEED, tmp_path,
                                  limits=Limits(time_scale=0.2, startup_s=60.0))
    tail = result.container.log_tail if result.container else ""
    assert result.status is EpisodeStatus.COMPLETED, (result.failure, tail)
    assert result.stages_reached == ("exploration", "planning", "execution")
    assert trace["gymnasium"] and "mujoco" not in trace["modules"]
    # The hooks wrote valid files at every stage end: the worker's file checks pass.
    assert {f.name: f.ok for f in result.files} == {"world_model.json": True,
                                                    "episode_log.jsonl": True}
    assert [(e["stage"], e["ended_by"], e["reason"], e["steps"]) for e in trace["ends"]] == [
        ("exploration", "client", "max_steps", EXPLORE_STEPS),
        ("planning", "client", "not played", 0),
        ("execution", "client", "max_steps", EXECUTE_STEPS)]
    assert "instruction" in trace["ends"][1]["messages"]  # planning's messages reach the hook
    assert trace["actions"] == EXPLORE_STEPS + EXECUTE_STEPS == result.stats.steps
    assert trace["stages"] == ["exploration"] * EXPLORE_STEPS + ["execution"] * EXECUTE_STEPS
    assert set(trace["rewards"]) == {0.0}
    # Exploration is the offline episode of the same house, step for step: the same
    # observations (keys, dtypes, values) and so the same actions from the same policy.
    for i, (obs, action) in enumerate(zip(offline_obs, offline_actions, strict=True)):
        online = {k.split("/")[2]: v for k, v in arrays.items() if k.startswith(f"obs/{i}/")}
        assert sorted(online) == sorted(obs), i
        for name, value in obs.items():
            assert online[name].dtype == value.dtype, (i, name)
            if name in ("rgb", "depth"):  # rendered in two processes: allow a pixel's noise
                assert np.mean(online[name] != value) < 0.01, (i, name)
            else:
                assert np.array_equal(online[name], value), (i, name)
        sent = {k.split("/")[2]: v for k, v in arrays.items() if k.startswith(f"action/{i}/")}
        assert sorted(sent) == sorted(action), i
        assert all(np.array_equal(sent[k], v) for k, v in action.items()), i
    assert result.stats.invalid_actions < result.stats.steps


def _offline_arena() -> int:
    """The sanity policy on ``gymnasium.make("eagc/Sanity-v0")``: it reaches the target."""
    env = gymnasium.make("eagc/Sanity-v0")
    policy = ArenaPolicy()
    obs, _ = env.reset(seed=7)
    for step in range(1, 600):
        action = policy(obs)
        assert env.action_space.contains(action)
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated:
            return step
        assert not truncated
    raise AssertionError("the policy never reached the target offline")


def test_without_gymnasium_the_plain_client_plays_a_sanity_episode(tmp_path: Path) -> None:
    assert _offline_arena() > 0
    result, trace, arrays = _play("sanity", "challenge", 7, tmp_path, "plain")
    tail = result.container.log_tail if result.container else ""
    assert result.status is EpisodeStatus.COMPLETED, (result.failure, tail)
    assert not trace["gymnasium"] and trace["modules"] == []  # nothing heavy, no gymnasium
    assert trace["space"]["action"] == "PlainBox(-1.0, 1.0, (2,), float32)"
    assert {f.name: f.ok for f in result.files} == {"world_model.json": True,
                                                    "episode_log.jsonl": True}
    explore, reach = trace["ends"]
    # Ended by the client when the target came in sight (its files are in that snapshot);
    # the host ended the last stage when the robot reached the target (written after).
    assert (explore["stage"], explore["ended_by"], explore["reason"]) == (
        "explore", "client", "until")
    assert (reach["stage"], reach["ended_by"], reach["reason"], reach["last"]) == (
        "reach", "host", "host: completed", True)
    assert explore["steps"] + reach["steps"] == trace["actions"] == result.stats.steps
    assert result.score.total > 0.3, result.score


def test_the_client_refuses_calls_out_of_order(tmp_path: Path) -> None:
    env, offline = _track1_client(tmp_path)
    with pytest.raises(GymClientError, match="reset"):
        env.step({"primitive": 0})
    offline.close()


@pytest.mark.docker
@pytest.mark.slow
def test_the_agent_base_image_runs_the_policy_in_the_sandbox(tmp_path: Path) -> None:
    """The agent base image (no gymnasium) as built offline, this agent on top, the episode
    under the full sandbox."""
    from orchestrator._images.build import build_agent_base, build_folder
    from orchestrator._runtimes.docker import DockerRuntime, docker_client
    from orchestrator._runtimes.interface import InfraError

    try:
        client = docker_client()
    except InfraError as e:
        if os.environ.get("CI"):
            pytest.fail(f"CI must have a Docker engine: {e}")
        pytest.skip(f"no Docker engine here ({e}); CI always has one")
    # A tag of its own, always rebuilt, so that this test never runs an older client.
    base = build_agent_base(client, say=lambda m: None, force=True,
                            tag="eagc-test/agent-base-gym:latest")
    context = tmp_path / "image"
    context.mkdir()
    (context / "_gym_agent.py").write_text(AGENT.read_text())
    (context / "Dockerfile").write_text(
        f"FROM {base}\nCOPY _gym_agent.py /agent/_gym_agent.py\n"
        'CMD ["python3", "/agent/_gym_agent.py", "sanity", "-"]\n')
    image = build_folder(client, context, "eagc-test/gym-agent:latest", say=lambda m: None)
    result = run_episode(
        EpisodeSpec(track="sanity", image=image, seed=7, split="challenge", runs_dir=_runs(),
                    exit_grace_s=5.0),
        DockerRuntime(client),
    )
    tail = result.container.log_tail if result.container else ""
    assert result.status is EpisodeStatus.COMPLETED, (result.failure, tail)
    assert result.runtime == "docker"
    assert {f.name: f.ok for f in result.files} == {"world_model.json": True,
                                                    "episode_log.jsonl": True}
    line = next(x for x in tail.splitlines() if x.startswith("gym agent: "))
    summary = json.loads(line.removeprefix("gym agent: "))
    assert (summary["gymnasium"], summary["modules"]) == (False, [])
    assert summary["ends"] == [["explore", "client", "until"],
                               ["reach", "host", "host: completed"]]
