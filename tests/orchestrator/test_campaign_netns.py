"""A worker node cut off mid-episode, for real: two Ray nodes in two network namespaces.

The head (and the driver) live in one namespace, a worker node in another, joined by a veth
pair with addresses of their own (198.18.N.1 and .2, the benchmarking range, used nowhere
else). Both nodes use this machine's Docker engine and /tmp, as two machines would use
their own engines and a shared runs folder. Once an episode runs on the worker node its
link goes down: Ray declares the node dead, its episodes are retried on the head (charged:
the fault was on their node), and when the link comes back its raylet learns it was
declared dead and leaves, so its orphaned containers lose their heartbeat and are reaped.
Nothing is lost, nothing is committed twice, and the progress board lived on the head.

Needs root (``ip netns``); CI is root. GCS health checks and the heartbeat's staleness are
shortened (environment) so that the test takes about a minute.
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import sqlite3
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import docker
import pytest
from test_campaign_helpers import (
    build_campaign_images,
    end_processes,
    processes_mentioning,
    short_dir,
    write_campaign,
)

pytestmark = [pytest.mark.docker, pytest.mark.slow]

WAITING = {"waiting": "eagc-test/waiting:latest"}


def _ip(*args: str, ns: str | None = None) -> None:
    cmd = ["ip", "netns", "exec", ns, "ip", *args] if ns else ["ip", *args]
    subprocess.run(cmd, check=True, capture_output=True)


class TwoHosts:
    """Two network namespaces joined by a veth pair; Ray head in one, a worker in the other."""

    def __init__(self) -> None:
        if os.geteuid() != 0 or shutil.which("ip") is None:
            if os.environ.get("CI"):
                pytest.fail("CI runs as root with iproute2")
            pytest.skip("needs root and iproute2 (ip netns)")
        tag = secrets.token_hex(3)
        self.head_ns, self.worker_ns = f"eagc-h{tag}", f"eagc-w{tag}"
        self.veth_h, self.veth_w = f"eh{tag}", f"ew{tag}"
        n = int(tag[:2], 16) % 250 + 1
        self.head_ip, self.worker_ip = f"198.18.{n}.1", f"198.18.{n}.2"
        self.temp = short_dir("eagc-nn-")
        self.port = 6379 + n  # inside the namespace: nothing else listens there
        self.address = f"{self.head_ip}:{self.port}"
        self.env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_USAGE_STATS_ENABLED": "0",
                    "RAY_AUTH_TOKEN": secrets.token_hex(32),
                    "RAY_health_check_period_ms": "1000",
                    "RAY_health_check_timeout_ms": "1000",
                    "RAY_health_check_failure_threshold": "3",
                    "EAGC_HEARTBEAT_STALE_S": "6",
                    "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
        for ns in (self.head_ns, self.worker_ns):
            subprocess.run(["ip", "netns", "add", ns], check=True)
            _ip("link", "set", "lo", "up", ns=ns)
        _ip("link", "add", self.veth_h, "type", "veth", "peer", "name", self.veth_w)
        _ip("link", "set", self.veth_h, "netns", self.head_ns)
        _ip("link", "set", self.veth_w, "netns", self.worker_ns)
        _ip("addr", "add", f"{self.head_ip}/24", "dev", self.veth_h, ns=self.head_ns)
        _ip("addr", "add", f"{self.worker_ip}/24", "dev", self.veth_w, ns=self.worker_ns)
        _ip("link", "set", self.veth_h, "up", ns=self.head_ns)
        _ip("link", "set", self.veth_w, "up", ns=self.worker_ns)

    def run(self, ns: str, *cmd: str, **kw: Any) -> Any:
        return subprocess.Popen(["ip", "netns", "exec", ns, *cmd], env=self.env, **kw)

    def ray_start(self, ns: str, *args: str) -> None:
        ray = str(Path(sys.executable).with_name("ray"))
        p = self.run(ns, ray, "start", *args, "--disable-usage-stats",
                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        out, _ = p.communicate(timeout=120)
        assert p.returncode == 0, out[-3000:]

    def link(self, up: bool) -> None:
        _ip("link", "set", self.veth_w, "up" if up else "down", ns=self.worker_ns)

    def stop(self) -> None:
        end_processes(processes_mentioning(str(self.temp)))
        for ns in (self.head_ns, self.worker_ns):
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)
        shutil.rmtree(self.temp, ignore_errors=True)


def _events(folder: Path, name: str) -> list[dict[str, Any]]:
    path = folder / "out" / name / "events.jsonl"
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def test_a_worker_node_cut_off_mid_episode(docker_engine: Any) -> None:
    build_campaign_images(docker_engine, "waiting")
    hosts = TwoHosts()
    try:
        hosts.ray_start(hosts.head_ns, "--head", f"--port={hosts.port}",
                        f"--node-ip-address={hosts.head_ip}", f"--temp-dir={hosts.temp}/h",
                        "--num-cpus=2", '--resources={"eagc_slot": 2}',
                        "--include-dashboard=false")
        hosts.ray_start(hosts.worker_ns, f"--address={hosts.address}",
                        f"--node-ip-address={hosts.worker_ip}", f"--temp-dir={hosts.temp}/w",
                        "--num-cpus=2",
                        '--resources={"eagc_slot": 2}')
        folder = short_dir("eagc-nc-")
        name = "cut-off-" + os.urandom(3).hex()  # unique on a shared engine
        # ~25 s episodes: 125 steps of 0.1 s in each of two stages.
        path = write_campaign(folder, name, WAITING, standard=2, challenge=2, retries=2,
                              limits={"memory_mb": 256, "max_steps_per_stage": 125})
        driver = hosts.run(hosts.head_ns, sys.executable, "-m", "orchestrator.cli.campaign",
                           "run", str(path), "--address", hosts.address, "--no-progress",
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           cwd=Path(__file__).resolve().parents[2])
        engine = docker.from_env()
        head_node = None
        cut: list[dict[str, Any]] = []
        deadline = time.time() + 120
        while time.time() < deadline and not cut:
            assert driver.poll() is None, driver.communicate()[1][-3000:]
            events = _events(folder, name)
            head_node = next((e["board_node"] for e in events if e["event"] == "submitted"),
                             None)
            cut = [e for e in events if e["event"] == "started" and head_node
                   and e["node"] != head_node and engine.containers.list(
                       filters={"label": f"eagc.episode={e['episode']}",
                                "status": "running"})]
            time.sleep(0.5)
        assert cut, "no episode ran in a container on the worker node"
        orphans = [e["episode"] for e in _events(folder, name)
                   if e["event"] == "started" and e["node"] != head_node]
        hosts.link(up=False)
        # Ray declares the node dead (health checks); the driver retries its episodes.
        deadline = time.time() + 90
        while time.time() < deadline and not [
                e for e in _events(folder, name) if e["event"] == "retry"]:
            time.sleep(0.5)
        assert all(engine.containers.list(filters={"label": f"eagc.episode={e['episode']}"})
                   for e in cut), "the cut-off node's containers went before it came back"
        hosts.link(up=True)  # it comes back: its raylet leaves, its workers with it
        gone_by = time.time() + 60
        while time.time() < gone_by and any(engine.containers.list(
                all=True, filters={"label": f"eagc.episode={ep}"}) for ep in orphans):
            time.sleep(0.5)
        left = [ep for ep in orphans if engine.containers.list(
            all=True, filters={"label": f"eagc.episode={ep}"})]
        assert left == [], f"orphaned containers of the cut-off node were not reaped: {left}"
        _, err = driver.communicate(timeout=300)
        assert driver.returncode == 0, err[-3000:]

        events = _events(folder, name)
        t0 = events[0]["at"]
        for e in events:  # the timeline, for whoever reads a failure
            print(f"{e['at'] - t0:7.1f} {e['event']} {e.get('split', '')}/{e.get('index', '')}"
                  f" #{e.get('retry', '')} {str(e.get('node'))[:8]}")
        retried = {(e["split"], e["index"]) for e in events if e["event"] == "retry"}
        assert retried and all(e["node"] != head_node for e in events
                               if e["event"] == "retry")
        assert "was lost" in next(e["message"] for e in events if e["event"] == "retry")
        committed = [(e["split"], e["index"]) for e in events if e["event"] == "committed"]
        assert sorted(committed) == sorted(set(committed)) and len(committed) == 4
        db = sqlite3.connect(folder / "out" / "results.sqlite")
        rows = db.execute("SELECT split, idx, node, retry FROM episodes WHERE campaign=?",
                          (name,)).fetchall()
        assert len(rows) == 4 and len({r[:2] for r in rows}) == 4
        for split, idx, node, retry in rows:
            if (split, idx) in retried:
                assert node == head_node and retry >= 1
        assert not db.execute("SELECT COUNT(*) FROM quarantine").fetchone()[0]
    finally:
        hosts.stop()
