"""docker-compose's Ray head comes up with token authentication, as deploy/README.md says.

The worker image is built offline by deploy/worker/build.sh (``FROM eagc/base:bookworm``:
no registry, the wheels downloaded on the host first). Only the ``ray-head`` service is
started (Prometheus and Grafana images need a registry or their archives, see
deploy/README.md), on free ports and under a compose project of its own; a driver inside
it joins the cluster with the token and sees the head's container slot.
"""

from __future__ import annotations

import os
import secrets
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest
from test_campaign_helpers import free_port, short_dir

pytestmark = [pytest.mark.docker, pytest.mark.slow]

DEPLOY = Path(__file__).resolve().parents[2] / "deploy"
TAG = "eagc-test/worker:latest"
PROBE = ("import ray; ray.init(address='auto', logging_level='ERROR'); "
         "print('slots', ray.cluster_resources().get('eagc_slot'))")


def test_compose_ray_head_starts_with_token_auth(docker_engine: Any) -> None:
    from orchestrator._images.build import BASE_IMAGE, build_base

    build_base(docker_engine, lambda m: None)
    r = subprocess.run(["bash", str(DEPLOY / "worker" / "build.sh"), TAG],
                       env={**os.environ, "BASE": BASE_IMAGE}, capture_output=True, text=True,
                       timeout=1200)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    project = "eagc-test-" + secrets.token_hex(4)
    env = {**os.environ, "EAGC_HOME": str(short_dir("eagc-ch-")), "EAGC_WORKER_IMAGE": TAG,
           "RAY_AUTH_TOKEN": secrets.token_hex(32), "EAGC_RAY_PORT": str(free_port()),
           "EAGC_SLOTS": "1"}
    compose = ["docker-compose", "-p", project, "-f", str(DEPLOY / "docker-compose.yml")]
    try:
        up = subprocess.run([*compose, "up", "-d", "ray-head"], env=env, capture_output=True,
                            text=True, timeout=300)
        assert up.returncode == 0, up.stderr[-2000:]
        deadline, last = time.time() + 120, ""
        while time.time() < deadline:
            probe = subprocess.run([*compose, "exec", "-T", "ray-head", "python3", "-c", PROBE],
                                   env=env, capture_output=True, text=True, timeout=120)
            last = probe.stdout + probe.stderr
            if "slots 1.0" in probe.stdout:
                break
            time.sleep(2)
        assert "slots 1.0" in last, last[-2000:]
        (cid,) = subprocess.run([*compose, "ps", "-q", "ray-head"], env=env,
                                capture_output=True, text=True).stdout.split()
        state = docker_engine.containers.get(cid).attrs
        assert state["RestartCount"] == 0 and state["State"]["Running"]
        assert "Token authentication" not in docker_engine.containers.get(cid).logs().decode()
    finally:
        subprocess.run([*compose, "down", "-v", "--timeout", "5"], env=env,
                       capture_output=True, timeout=120)
