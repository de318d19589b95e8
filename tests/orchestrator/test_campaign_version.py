"""Driver and workers must run the same eagc code: a worker that runs other code refuses.

Real embedded Ray; the digest the driver sends is faked (its ``submit`` is wrapped in this
process only: Ray ships ``episode_task`` by value with the globals it uses, so patching
``code_version`` would reach the workers too), and every worker, which computes the digest
of the real tree, sees a skew. The local runtime is enough: the check comes before any
agent starts.
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Any

import pytest
import yaml
from test_campaign_helpers import short_dir, write_campaign

import orchestrator._campaign.fanout as fanout
from orchestrator._campaign.driver import run_campaign
from orchestrator._campaign.driver_io import CampaignOptions
from orchestrator._campaign.spec import load_campaign


def test_code_version_follows_the_sources(tmp_path: Path) -> None:
    for package in fanout._PACKAGES:
        (tmp_path / package).mkdir()
        (tmp_path / package / "__init__.py").write_text("x = 1\n")
    first = fanout.code_version(tmp_path)
    assert first == fanout.code_version.__wrapped__(tmp_path)  # stable
    (tmp_path / "simhost" / "__init__.py").write_text("x = 2\n")
    assert fanout.code_version.__wrapped__(tmp_path) != first
    assert fanout.code_version() != first  # the real tree


def test_a_worker_running_other_code_runs_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    real_submit = fanout.submit

    def submit(job: fanout.EpisodeJob, board: Any) -> Any:
        return real_submit(dataclasses.replace(job, code="0123456789abcdef"), board)

    monkeypatch.setattr(fanout, "submit", submit)
    folder = short_dir("eagc-vs-")
    name = "skew-" + os.urandom(3).hex()
    path = write_campaign(folder, name, {"team": "python -c pass"}, standard=1,
                          challenge=1, retries=1)
    doc = yaml.safe_load(path.read_text())
    path.write_text(yaml.safe_dump({**doc, "runtime": "local"}))
    report = run_campaign(load_campaign(path), CampaignOptions(workers=1, progress=False))
    assert report.committed == 0 and report.quarantined == 2 and report.retries == 2
    events = [json.loads(line) for line in
              (folder / "out" / name / "events.jsonl").read_text().splitlines()]
    held = [e for e in events if e.get("event", e.get("kind")) == "quarantined"]
    assert len(held) == 2, events
    for e in held:
        assert "version skew" in e["message"] and "0123456789abcdef" in e["message"], e
