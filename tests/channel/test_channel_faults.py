"""The channel's faults with its real parts (issue 33 §5): kill -9 of the channel while a
submission runs, and of its registry. On restart every submission is in exactly one state,
none is lost, charged twice or run twice; nothing is left running."""

from __future__ import annotations

import json
import os
import signal
import time
from collections.abc import Callable
from pathlib import Path

import docker
import pytest
import requests
import yaml
from test_channel_e2e import EXAMPLE, SANITY, Served

pytestmark = [pytest.mark.docker]


def _until(what: Callable[[], object], timeout: float, why: str) -> object:
    deadline = time.monotonic() + timeout
    while True:
        got = what()
        if got:
            return got
        assert time.monotonic() < deadline, why
        time.sleep(0.5)


def _pids(fragment: str) -> list[int]:
    """Processes whose command line holds ``fragment``."""
    found = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if fragment in (d / "cmdline").read_bytes().replace(b"\0", b" ").decode():
                    found.append(int(d.name))
            except OSError:
                continue
    return found


def _challenge(tmp_path: Path, **changes: object) -> Path:
    doc = yaml.safe_load(EXAMPLE.read_text())
    doc.update(changes)
    path = tmp_path / "challenge.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def _view(ch: Served, sid: str) -> dict[str, object]:
    r = requests.get(f"{ch.url}/api/v1/submissions/{sid}", timeout=10,
                     headers={"Authorization": f"Bearer {ch.tokens['team-a']}"})
    assert r.status_code == 200, r.text
    view: dict[str, object] = r.json()
    return view


@pytest.mark.slow
def test_kill_9_of_the_channel_while_it_runs_loses_nothing_and_runs_nothing_twice(
        images: dict[str, str], tmp_path: Path) -> None:
    challenge = _challenge(tmp_path, lease_s=10)
    ch = Served(runner=True, challenge=challenge)
    try:
        ch.login("team-a")
        sub = ch.eagc("submit", SANITY, "--json", team="team-a")
        assert sub.returncode == 0, sub.stderr
        sid = json.loads(sub.stdout)["id"]
        _until(lambda: _view(ch, sid)["state"] == "running", 300, "never ran")

        os.kill(ch.proc.pid, signal.SIGKILL)  # the channel alone
        ch.proc.wait(10)
        # Its registry and its runner go with it (the runner through its cancel path).
        _until(lambda: not _pids(f"{ch.data}/registry/config.yml"), 10, "registry left")
        _until(lambda: not _pids(f"--runs {ch.data}/runs"), 90, "runner left")
        campaign = "sanity-demo-open"
        _until(lambda: not docker.from_env().containers.list(
            filters={"label": f"eagc.campaign={campaign}"}), 90, "containers left")

        token = ch.tokens["team-a"]
        ch = Served(runner=True, challenge=challenge, data=ch.data)  # same data
        ch.tokens["team-a"] = token
        done = _until(lambda: (v := _view(ch, sid))["state"] in ("scored", "failed") and v,
                      600, "never ended after the restart")
        assert isinstance(done, dict) and done["state"] == "scored", done
        states = [h["state"] for h in done["history"]]
        assert states.count("scored") == 1 and states[-1] == "scored"
        assert any("lease expired" in h["detail"] for h in done["history"]), states
        assert done["episodes_done"] == done["episodes_planned"] == 4
        listing = requests.get(f"{ch.url}/api/v1/submissions", timeout=10,
                               headers={"Authorization": f"Bearer {token}"}).json()
        assert [v["id"] for v in listing] == [sid]  # nothing lost, nothing doubled
        quota = requests.get(f"{ch.url}/api/v1/quota", timeout=10,
                             headers={"Authorization": f"Bearer {token}"}).json()
        assert quota["used"] == 1  # charged once
    finally:
        ch.stop()


def test_a_killed_registry_is_started_again_and_pushes_resume(
        images: dict[str, str]) -> None:
    ch = Served(runner=False)
    try:
        ch.login("team-a")
        conf = f"{ch.data}/registry/config.yml"
        (pid,) = _pids(conf)
        os.kill(pid, signal.SIGKILL)
        _until(lambda: [p for p in _pids(conf) if p != pid], 30, "registry not restarted")
        sub = _until(lambda: (r := ch.eagc("submit", SANITY, "--json", team="team-a"))
                     .returncode == 0 and r, 60, "no push after the restart")
        view = json.loads(sub.stdout)  # type: ignore[union-attr]
        assert view["state"] == "received"
        metrics = requests.get(f"{ch.url}/metrics", timeout=10).text
        assert 'eagc_channel_submissions{phase="open",state="received"} 1.0' in metrics
        assert "eagc_channel_registry_storage_bytes" in metrics
    finally:
        ch.stop()
