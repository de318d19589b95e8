"""One campaign across a two-node Ray cluster started on this machine with `ray start`."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from typing import Any

import docker
import pytest
from test_campaign_helpers import RayCluster, build_campaign_images, short_dir, write_campaign

from orchestrator._campaign.spec import load_campaign, store_path
from orchestrator._results.store import ResultsStore

pytestmark = [pytest.mark.docker, pytest.mark.slow]


def test_campaign_runs_on_both_nodes(docker_engine: Any) -> None:
    build_campaign_images(docker_engine)
    cluster = RayCluster()
    try:
        # Different resources per node: the head offers one slot, the second node two.
        cluster.start_head(cpus=1, resources={"eagc_slot": 1, "head_only": 1})
        cluster.add_node(cpus=2, resources={"eagc_slot": 2, "second_only": 1})
        folder = short_dir("eagc-cc-")
        name = "two-nodes-" + os.urandom(3).hex()  # unique on a shared engine
        path = write_campaign(folder, name, {"baseline": "eagc/sanity-agent:latest"},
                              standard=3, challenge=3)
        spec = load_campaign(path)
        # The driver is a process of its own, joining with the token like any other.
        r = subprocess.run(
            [sys.executable, "-m", "orchestrator.cli.campaign", "run", str(path),
             "--address", cluster.address, "--no-progress"],
            env=cluster.env, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stdout + r.stderr
        assert "6 committed this run" in r.stderr
        with ResultsStore(store_path(spec)) as store:
            stored = store.results(spec.name)
        nodes = {e.node for e in stored}
        assert len(nodes) == 2, f"results came from {nodes}, not from both nodes"
        events = [json.loads(line) for line in
                  (folder / "out" / spec.name / "events.jsonl").read_text().splitlines()]
        assert {e["node"] for e in events if e["event"] == "started"} == nodes
        assert all(e.result.status.value == "completed" for e in stored)
        left = docker.from_env().containers.list(
            all=True, filters={"label": f"eagc.campaign={spec.name}"})
        assert left == []
    finally:
        cluster.stop()
