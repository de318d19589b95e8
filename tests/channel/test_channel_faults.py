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


def _challenge(tmp_path: Path, phase: dict[str, object] | None = None,
               **changes: object) -> Path:
    """The example challenge with ``changes`` (and ``phase``'s in its one phase)."""
    doc = yaml.safe_load(EXAMPLE.read_text())
    doc.update(changes)
    doc["phases"][0].update(phase or {})
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


@pytest.mark.slow
def test_a_run_its_runner_dies_in_is_refunded_without_a_human(
        images: dict[str, str], tmp_path: Path) -> None:
    """kill -9 of the runner alone, in a phase that retries nothing: the lease runs out,
    the submission fails as the platform's fault and the team gets its quota back."""
    ch = Served(runner=True, challenge=_challenge(tmp_path, {"retries": 0}, lease_s=10))
    try:
        ch.login("team-a")
        sub = ch.eagc("submit", SANITY, "--json", team="team-a")
        assert sub.returncode == 0, sub.stderr
        sid = json.loads(sub.stdout)["id"]
        _until(lambda: _view(ch, sid)["state"] == "running", 300, "never ran")
        (runner,) = _pids(f"--runs {ch.data}/runs")
        os.kill(runner, signal.SIGKILL)
        done = _until(lambda: (v := _view(ch, sid))["state"] == "failed" and v, 60,
                      "the lost run was not failed")
        assert isinstance(done, dict)
        assert "its runner stopped answering" in str(done["reason"])
        assert "refunded" in str(done["reason"]) and not done["charged"]
        quota = requests.get(f"{ch.url}/api/v1/quota", timeout=10, headers={
            "Authorization": f"Bearer {ch.tokens['team-a']}"}).json()
        assert (quota["used"], quota["refunded"]) == (0, 1)
        # Its containers go too (their episode watchers), and its embedded Ray.
        _until(lambda: not docker.from_env().containers.list(
            filters={"label": "eagc.campaign=sanity-demo-open"}), 120, "containers left")
    finally:
        ch.stop()


def test_kill_9_while_submissions_are_accepted_loses_none_it_answered(
        images: dict[str, str], tmp_path: Path) -> None:
    """Submissions by digest arrive from eight clients; the channel is killed in the middle
    of them. Restarted, every submission it answered is there, in exactly one state, with
    its history from the start; none is there twice."""
    import threading

    burst = {"quota": {"per_day": 5000, "concurrent": 5000}}  # a deadline's
    ch = Served(runner=False, challenge=_challenge(tmp_path, burst))
    data = ch.data
    try:
        ch.login("team-a")
        first = json.loads(ch.eagc("submit", SANITY, "--json", team="team-a").stdout)
        token = ch.tokens["team-a"]
        answered: list[str] = []
        stop = threading.Event()

        def client() -> None:
            s = requests.Session()
            while not stop.is_set():
                try:
                    r = s.post(f"{ch.url}/api/v1/submissions", timeout=5,
                               headers={"Authorization": f"Bearer {token}"},
                               json={"image": first["image"]})
                except requests.RequestException:
                    return  # the channel is gone
                if r.status_code == 201:
                    answered.append(r.json()["id"])

        threads = [threading.Thread(target=client) for _ in range(8)]
        for t in threads:
            t.start()
        _until(lambda: len(answered) >= 20, 60, "too few accepted")
        os.kill(ch.proc.pid, signal.SIGKILL)
        stop.set()
        for t in threads:
            t.join(10)
        ch = Served(runner=False, data=data)
        ch.tokens["team-a"] = token
        rows = requests.get(f"{ch.url}/api/v1/submissions", timeout=30,
                            headers={"Authorization": f"Bearer {token}"}).json()
        ids = [v["id"] for v in rows]
        assert len(ids) == len(set(ids))
        assert set(answered) <= set(ids), set(answered) - set(ids)
        for v in rows:
            assert v["state"] == "received", v
            assert [h["state"] for h in v["history"]] == ["received"]
        assert len(ids) <= len(answered) + 1 + 8  # at most one in flight per client
    finally:
        ch.stop()
