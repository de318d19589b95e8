"""Episodes in real containers under the full sandbox (docs/architecture.md, 'The sandbox')."""

from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from _support import RecordingRuntime  # tests/orchestrator/_support.py
from mcap.reader import make_reader

from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._runtimes.interface import AgentHandle, AgentLaunch
from schemas import EpisodeResult, EpisodeStatus, Limits, load_json

pytestmark = [pytest.mark.docker]

SECRET_SEED = 987654321


def _run(engine: Any, runs: Path, image: str, *, seed: int = 11,
         runtime: RecordingRuntime | None = None, **limits: Any
         ) -> tuple[EpisodeResult, RecordingRuntime]:
    runtime = runtime or RecordingRuntime(engine)
    spec = EpisodeSpec(track="sanity", image=image, seed=seed, split="challenge",
                       limits=Limits(**limits), runs_dir=runs, exit_grace_s=5.0)
    return run_episode(spec, runtime), runtime


def _assert_gone(engine: Any, result: EpisodeResult, runtime: RecordingRuntime) -> None:
    left = engine.containers.list(all=True, filters={"label": f"eagc.episode={result.episode}"})
    assert left == [], "the episode's container is still there"
    for attrs in runtime.inspected:
        pid = attrs["State"]["Pid"]
        assert pid and not Path(f"/proc/{pid}").exists(), f"process {pid} survived the episode"


def test_sanity_episode_end_to_end(docker_engine: Any, images: dict, runs_dir: Path) -> None:
    result, runtime = _run(docker_engine, runs_dir, "eagc/sanity-agent:latest", seed=5)
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    assert result.failure is None and result.runtime == "docker"
    assert result.score.total > 0.5
    assert result.stages_reached == ("explore", "reach")
    assert {f.name for f in result.files if f.ok} == {"world_model.json", "episode_log.jsonl"}
    assert result.stats.steps > 0 and result.stats.latency_ms_median is not None
    assert result.stats.peak_memory_bytes and result.stats.peak_memory_bytes > 1 << 20

    host = Path(result.episode_dir or "") / "host"
    assert load_json(host / "result.json", EpisodeResult) == result
    topics: dict[str, int] = {}
    scenario: dict[str, Any] = {}
    with open(host / "episode.mcap", "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            topics[channel.topic] = topics.get(channel.topic, 0) + 1
            if channel.topic == "/eagc/scenario":
                scenario = json.loads(message.data)
    assert scenario["seed"] == 5
    for topic in ("/eagc/scenario", "/eagc/request", "/eagc/reply", "/eagc/event",
                  "/eagc/state_hash", "/eagc/score", "/eagc/file/explore/world_model.json"):
        assert topics.get(topic), f"MCAP has no {topic}: {sorted(topics)}"
    assert topics["/eagc/state_hash"] == result.stats.steps

    # The sandbox, as the engine reports it.
    (attrs,) = runtime.inspected
    hc = attrs["HostConfig"]
    assert hc["NetworkMode"] == "none"
    assert hc["ReadonlyRootfs"] is True
    assert hc["CapDrop"] == ["ALL"]
    assert "no-new-privileges" in hc["SecurityOpt"]
    assert hc["PidsLimit"] == Limits().pids
    assert hc["Memory"] == hc["MemorySwap"] == Limits().memory_mb << 20
    assert hc["NanoCpus"] == int(Limits().cpus * 1e9)
    assert "size=" in hc["Tmpfs"]["/tmp"]
    assert attrs["Config"]["User"] == "10001:10001"
    assert attrs["Config"]["Labels"]["eagc.episode"] == result.episode
    mounts = {m["Destination"]: m for m in attrs["Mounts"]}
    assert set(mounts) == {"/run/eagc", "/output"}
    assert mounts["/run/eagc"]["RW"] is False
    # The agent's cores are apart from the sim host's (CI's two cores make one placement).
    cpus = scenario["cpus"]
    if len(os.sched_getaffinity(0)) >= 2:
        assert cpus is not None and not set(cpus["host"]) & set(cpus["agent"]), cpus
        assert hc["CpusetCpus"] == ",".join(map(str, cpus["agent"]))
    else:
        assert cpus is None and not hc["CpusetCpus"]
    _assert_gone(docker_engine, result, runtime)


def test_sandbox_probe_learns_nothing(docker_engine: Any, images: dict, runs_dir: Path) -> None:
    result, runtime = _run(docker_engine, runs_dir, images["probe"], seed=SECRET_SEED)
    assert result.status is EpisodeStatus.AGENT_CRASH  # it leaves without playing
    found = json.loads((Path(result.episode_dir or "") / "host/output/probe.json").read_text())
    assert found["uid"] == 10001
    for key in ("tcp_outside", "tcp_host_gateway", "tcp_host_loopback", "dns"):
        assert found[key].startswith("failed"), (key, found[key])
    assert found["write_etc"].startswith("failed") and not found["root_writable"]
    # Zenoh: only its own admin space and its own episode's agent keys.
    own = f"@/{found['zid']}"
    agent_keys = f"eagc/v1/{result.episode}/agent/"
    for reply in found["get_replies"]:
        key = reply["key"]
        assert key is None or key.startswith(own) or key.startswith(agent_keys), reply
    assert all(k.startswith(agent_keys) for k in found["sub_seen"]), found["sub_seen"]
    # No seed, ground truth or organizer path in its environment or mounts.
    assert set(found["env"]) <= {"EAGC_ENDPOINT", "EAGC_EPISODE", "EAGC_OUTPUT", "HOME",
                                 "PYTHONUNBUFFERED", "PATH", "HOSTNAME", "PYTHONDONTWRITEBYTECODE",
                                 "LC_CTYPE"}  # LC_CTYPE: set by Python itself (PEP 538)
    everything = json.dumps(found)
    assert str(SECRET_SEED) not in everything
    assert str(runs_dir) not in everything
    assert "target" not in json.dumps(found["env"]) + found["mounts"]
    _assert_gone(docker_engine, result, runtime)


def test_oom_is_an_agent_failure(docker_engine: Any, images: dict, runs_dir: Path) -> None:
    result, runtime = _run(docker_engine, runs_dir, images["oom"], memory_mb=96)
    assert result.status is EpisodeStatus.AGENT_OOM
    assert result.failure is not None and result.failure.kind == "agent"
    assert result.failure.oom_killed and "memory" in (result.failure.limit_hit or "")
    assert result.failure.stage_reached == "explore"
    _assert_gone(docker_engine, result, runtime)


def test_crash_is_an_agent_failure(docker_engine: Any, images: dict, runs_dir: Path) -> None:
    result, runtime = _run(docker_engine, runs_dir, images["crash"])
    assert result.status is EpisodeStatus.AGENT_CRASH
    assert result.failure is not None and result.failure.exit_code == 3
    assert not result.failure.oom_killed
    assert "about to crash" in result.failure.log_tail
    assert result.stats.steps == 5
    _assert_gone(docker_engine, result, runtime)


def test_frozen_agent_ends_with_its_stage_budgets(
    docker_engine: Any, images: dict, runs_dir: Path
) -> None:
    result, runtime = _run(docker_engine, runs_dir, images["frozen"], time_scale=0.04)
    assert result.status is EpisodeStatus.AGENT_TIMEOUT
    assert result.failure is not None and result.failure.limit_hit == "stage budget of 'reach'"
    assert result.stages_reached == ("explore", "reach")
    assert result.container is not None and result.container.killed_by_host
    _assert_gone(docker_engine, result, runtime)


def _processes_of(container_id: str) -> dict[int, str]:
    """This machine's processes in the container's cgroup (pid -> command line): the
    container's own, never another test's or another user's."""
    found: dict[int, str] = {}
    for p in os.listdir("/proc"):
        if not p.isdigit():
            continue
        try:
            if container_id not in Path(f"/proc/{p}/cgroup").read_text():
                continue
            found[int(p)] = Path(f"/proc/{p}/cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:  # it went meanwhile
            continue
    return found


class _WatchingRuntime(RecordingRuntime):
    """Also notes the processes of each container while it runs (by its cgroup)."""

    def __init__(self, client: Any) -> None:
        super().__init__(client)
        self.seen: dict[str, dict[int, str]] = {}
        self.watchers: list[threading.Thread] = []

    def start(self, launch: AgentLaunch) -> AgentHandle:
        handle = super().start(launch)
        seen = self.seen.setdefault(handle.id, {})

        def watch() -> None:
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline:
                now = _processes_of(handle.id)
                seen.update(now)
                if sum("sleep 3600" in c for c in seen.values()) >= 3 or (seen and not now):
                    return
                time.sleep(0.05)

        self.watchers.append(threading.Thread(target=watch, daemon=True))
        self.watchers[-1].start()
        return handle


def test_silent_agent_and_its_children_are_gone(
    docker_engine: Any, images: dict, runs_dir: Path
) -> None:
    runtime = _WatchingRuntime(docker_engine)
    result, _ = _run(docker_engine, runs_dir, images["silent"], runtime=runtime,
                     startup_s=3.0)
    assert result.status is EpisodeStatus.AGENT_TIMEOUT
    assert result.failure is not None and "never connected" in result.failure.message
    assert result.score.total == pytest.approx(0.0, abs=0.15)
    _assert_gone(docker_engine, result, runtime)
    for t in runtime.watchers:
        t.join(timeout=10)
    ((cid, seen),) = runtime.seen.items()
    children = [pid for pid, cmd in seen.items() if "sleep 3600" in cmd]
    assert len(children) == 3, f"the container's three children were never seen: {seen}"
    assert _processes_of(cid) == {}, "a process of the container survived it"


def test_hostile_files_are_refused(docker_engine: Any, images: dict, runs_dir: Path) -> None:
    result, runtime = _run(docker_engine, runs_dir, images["bad_files"], output_file_mb=1)
    assert result.status is EpisodeStatus.AGENT_BAD_FILES
    checks = {f.name: f for f in result.files}
    assert "symbolic link" in checks["world_model.json"].reason
    assert "FIFO" in checks["pipe.json"].reason
    assert "exceeds the cap" in checks["huge.bin"].reason
    assert checks["episode_log.jsonl"].ok
    assert result.score.components["model"] == 0.0 or result.score.total < 1.0
    _assert_gone(docker_engine, result, runtime)


def test_missing_image_never_starts(docker_engine: Any, images: dict, runs_dir: Path) -> None:
    result, _ = _run(docker_engine, runs_dir, "eagc-test/does-not-exist:latest")
    assert result.status is EpisodeStatus.AGENT_NO_START
    assert result.failure is not None and result.failure.kind == "agent"
    assert result.score.total == 0.0
