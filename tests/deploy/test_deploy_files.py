"""deploy/: checked as far as this machine can (no Kubernetes, no second host here).

promtool checks the Prometheus config and alert rules; docker-compose resolves the compose
file; the Ray cluster config is validated against the schema the installed Ray ships; the
KubeRay manifest is parsed and its structure checked (it is untested on a cluster, as
deploy/README.md says). The PromQL of the dashboard and the rules is evaluated against a
real Prometheus in tests/orchestrator/test_campaign_local.py.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

DEPLOY = Path(__file__).resolve().parents[2] / "deploy"


def _tool(name: str, package: str) -> str:
    path = shutil.which(name)
    if path is None:
        msg = f"{name} is not installed (apt-get install {package})"
        if os.environ.get("CI"):
            pytest.fail(f"CI must have it: {msg}")
        pytest.skip(msg)
    return path


def test_promtool_accepts_config_and_rules() -> None:
    promtool = _tool("promtool", "prometheus")
    for args in (["check", "config", str(DEPLOY / "prometheus" / "prometheus.yml")],
                 ["check", "rules", str(DEPLOY / "prometheus" / "alerts.yml")]):
        r = subprocess.run([promtool, *args], capture_output=True, text=True)
        assert r.returncode == 0, r.stdout + r.stderr
    rules = yaml.safe_load((DEPLOY / "prometheus" / "alerts.yml").read_text())
    names = {r["alert"] for g in rules["groups"] for r in g["rules"]}
    assert {"EagcCampaignStuck", "EagcHighFailureRate", "EagcNoProgress", "EagcTeamFailing",
            "EagcDriverDown"} <= names
    config = yaml.safe_load((DEPLOY / "prometheus" / "prometheus.yml").read_text())
    # Ray's metrics agent needs ray[default], which the worker image does not have: a `ray`
    # job would always be down (issue 13 §11), so there is none.
    assert [j["job_name"] for j in config["scrape_configs"]] == ["eagc-driver"]


def test_alert_rules_pass_their_unit_tests() -> None:
    """deploy/prometheus/alerts_test.yml: a team failing most of its episodes, a driver
    that stopped reporting mid-campaign (and not one that finished), first failures counted
    from series that start at 0."""
    promtool = _tool("promtool", "prometheus")
    r = subprocess.run([promtool, "test", "rules", "alerts_test.yml"], capture_output=True,
                       text=True, cwd=DEPLOY / "prometheus")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "SUCCESS" in r.stdout + r.stderr


def test_compose_file_resolves() -> None:
    compose = _tool("docker-compose", "docker-compose")
    env = {k: v for k, v in os.environ.items() if k != "RAY_AUTH_TOKEN"}
    r = subprocess.run([compose, "-f", str(DEPLOY / "docker-compose.yml"), "config"],
                       capture_output=True, text=True, env={**env, "EAGC_HOME": "/srv/x"})
    assert r.returncode != 0 and "RAY_AUTH_TOKEN" in r.stderr  # no token: a clear refusal
    r = subprocess.run([compose, "-f", str(DEPLOY / "docker-compose.yml"), "config"],
                       capture_output=True, text=True,
                       env={**env, "EAGC_HOME": "/srv/x", "RAY_AUTH_TOKEN": "t0ken"})
    assert r.returncode == 0, r.stderr
    doc = yaml.safe_load(r.stdout)
    assert set(doc["services"]) == {"ray-head", "prometheus", "grafana"}
    head = doc["services"]["ray-head"]
    volumes = [str(v) for v in head["volumes"]]
    # Episode folders keep the same path inside and out; the engine is the host's.
    assert any("/srv/x:/srv/x" in v or ("source': '/srv/x'" in v and "target': '/srv/x'" in v)
               for v in volumes), volumes
    assert any("docker.sock" in v for v in volumes)
    assert "eagc_slot" in " ".join(head["command"])
    assert head["environment"]["RAY_AUTH_MODE"] == "token"
    assert head["environment"]["RAY_AUTH_TOKEN"] == "t0ken"


def test_ray_cluster_config_matches_rays_schema() -> None:
    import jsonschema
    import ray

    schema = json.loads((Path(ray.__file__).parent / "autoscaler" / "ray-schema.json")
                        .read_text())
    config = yaml.safe_load((DEPLOY / "ray" / "cluster.yaml").read_text())
    jsonschema.validate(config, schema)
    starts = " ".join(config["head_start_ray_commands"] + config["worker_start_ray_commands"])
    assert starts.count("eagc_slot") == 2
    assert "/var/run/docker.sock" in " ".join(config["docker"]["run_options"])


def test_kuberay_manifest_parses() -> None:
    (doc,) = list(yaml.safe_load_all((DEPLOY / "kuberay" / "raycluster.yaml").read_text()))
    assert doc["apiVersion"] == "ray.io/v1" and doc["kind"] == "RayCluster"
    spec = doc["spec"]
    pods = [spec["headGroupSpec"]["template"]["spec"]] + [
        g["template"]["spec"] for g in spec["workerGroupSpecs"]]
    for pod in pods:
        mounts = {m["mountPath"] for c in pod["containers"] for m in c["volumeMounts"]}
        assert {"/var/run/docker.sock", "/srv/eagc"} <= mounts
        host = {v["name"]: v.get("hostPath", {}).get("path") for v in pod["volumes"]}
        assert host["eagc-home"] == "/srv/eagc"  # the same path inside and out
        assert all(c["imagePullPolicy"] == "Never" for c in pod["containers"])
    for group in spec["workerGroupSpecs"]:
        resources = json.loads(json.loads(group["rayStartParams"]["resources"]))
        assert resources["eagc_slot"] > 0
    assert "UNTESTED ON A CLUSTER" in (DEPLOY / "kuberay" / "raycluster.yaml").read_text()
    assert "untested" in (DEPLOY / "README.md").read_text().lower()


def test_grafana_dashboard_is_complete() -> None:
    doc = json.loads((DEPLOY / "grafana" / "dashboards" / "eagc.json").read_text())
    exprs = " ".join(t["expr"] for p in doc["panels"] for t in p["targets"])
    for metric in ("eagc_campaign_episodes", "eagc_episodes_running", "eagc_episodes_total",
                   "eagc_episode_duration_seconds", "eagc_agent_step_latency_seconds",
                   "eagc_invalid_actions_total", "eagc_episode_retries_total",
                   "eagc_episode_score", "eagc_container_peak_memory_bytes",
                   "eagc_containers_reaped_total", "eagc_store_errors_total"):
        assert metric in exprs, f"no panel shows {metric}"
    ids = [p["id"] for p in doc["panels"]]
    assert len(ids) == len(set(ids))
    provisioning = yaml.safe_load(
        (DEPLOY / "grafana" / "provisioning" / "dashboards" / "eagc.yml").read_text())
    assert provisioning["providers"][0]["options"]["path"] == "/var/lib/grafana/dashboards"


def test_worker_image_is_built_offline_from_the_base() -> None:
    lines = (DEPLOY / "worker" / "Dockerfile").read_text().splitlines()
    assert "ARG BASE=eagc/base:bookworm" in lines and "FROM ${BASE}" in lines
    assert any("--no-index" in line for line in lines)
    build = (DEPLOY / "worker" / "build.sh").read_text()
    assert "docker build --network none" in build and "mmdebstrap" in build
    r = subprocess.run(["bash", "-n", str(DEPLOY / "worker" / "build.sh")], capture_output=True)
    assert r.returncode == 0, r.stderr
