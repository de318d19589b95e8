"""The channel with its real parts: `eagc challenge serve` (FastAPI on uvicorn, Debian's
CNCF registry in token mode, a runner on an embedded Ray), real `docker push`/`pull`
through the engine, and the team's commands as a team types them (`eagc login`, `submit`,
`submissions`), each team with its own config folder."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import docker
import pytest
import requests

pytestmark = [pytest.mark.docker]

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "challenges" / "sanity.yaml"
SANITY = "eagc/sanity-agent:latest"
CRASH = "eagc-test/crash:latest"


class Served:
    """One `eagc challenge serve` in a short private folder, and its teams' logins."""

    def __init__(self, runner: bool, challenge: Path = EXAMPLE,
                 data: Path | None = None) -> None:
        self.data = data or Path(tempfile.mkdtemp(prefix="eagc-ch-", dir="/tmp"))
        self.log = self.data.parent / f"{self.data.name}.log"
        (self.data / "serve.json").unlink(missing_ok=True)
        cmd = [sys.executable, "-m", "orchestrator.cli", "challenge", "serve", str(challenge),
               "--data", str(self.data), "--port", "0"]
        if not runner:
            cmd.append("--no-runner")
        self.proc = subprocess.Popen(cmd, stdout=self.log.open("ab"),
                                     stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.monotonic() + 60
        while not (self.data / "serve.json").is_file():
            assert self.proc.poll() is None, self.log.read_text()
            assert time.monotonic() < deadline, self.log.read_text()
            time.sleep(0.2)
        where = json.loads((self.data / "serve.json").read_text())
        self.url, self.registry = where["url"], where["registry"]
        while True:  # the API answers once uvicorn is up
            try:
                requests.get(self.url + "/api/v1/whoami", timeout=2)
                break
            except requests.ConnectionError:
                assert time.monotonic() < deadline, self.log.read_text()
                time.sleep(0.2)
        self.tokens: dict[str, str] = {}

    def token(self, team: str) -> str:
        out = self.eagc("challenge", "teams", "token", team, "--data", str(self.data))
        assert out.returncode == 0, out.stderr
        self.tokens[team] = out.stdout.strip().splitlines()[-1]
        return self.tokens[team]

    def env(self, team: str) -> dict[str, str]:
        home = self.data.parent / f"{self.data.name}-{team}"
        home.mkdir(exist_ok=True)
        env = {k: v for k, v in os.environ.items() if not k.startswith("EAGC_CHANNEL")}
        return {**env, "XDG_CONFIG_HOME": str(home), "COLUMNS": "80"}

    def eagc(self, *args: str, team: str | None = None,
             timeout: float = 120) -> subprocess.CompletedProcess[str]:
        env = self.env(team) if team else None
        return subprocess.run([sys.executable, "-m", "orchestrator.cli", *args], env=env,
                              capture_output=True, text=True, timeout=timeout)

    def login(self, team: str) -> None:
        out = self.eagc("login", self.url, "--team", team, "--token", self.token(team),
                        team=team)
        assert out.returncode == 0, out.stderr

    def stop(self, remove: bool = True) -> None:
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(60)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(10)
        if remove:
            shutil.rmtree(self.data, ignore_errors=True)


@pytest.fixture()
def channel_only(images: dict[str, str]) -> Iterator[Served]:
    served = Served(runner=False)
    try:
        yield served
    finally:
        served.stop()


@pytest.fixture()
def channel(images: dict[str, str]) -> Iterator[Served]:
    served = Served(runner=True)
    try:
        yield served
    finally:
        served.stop()


def _one_line(out: subprocess.CompletedProcess[str]) -> str:
    lines = [ln for ln in out.stderr.splitlines() if ln.strip()]
    assert out.returncode == 1 and lines and lines[-1].startswith("error: "), (
        out.returncode, out.stderr)
    return lines[-1]


def test_teams_reach_only_their_own_submissions_and_repositories(
        channel_only: Served) -> None:
    ch = channel_only
    ch.login("team-a")
    ch.login("team-b")
    sub = ch.eagc("submit", SANITY, "--note", "first", "--json", team="team-a")
    assert sub.returncode == 0, sub.stderr
    view = json.loads(sub.stdout)
    assert view["state"] == "received" and view["team"] == "team-a"
    assert view["image"].startswith("teams/team-a/sanity-agent@sha256:")
    local = docker.from_env().images.get(SANITY)
    assert view["history"][0]["detail"] == view["image"]

    # Team B: "not found" for A's submission, exactly as for one that does not exist.
    theirs = _one_line(ch.eagc("submissions", view["id"], team="team-b"))
    missing = _one_line(ch.eagc("submissions", "s-0000000000", team="team-b"))
    assert theirs.replace(view["id"], "ID") == missing.replace("s-0000000000", "ID")
    assert "no submission" in theirs

    # Team B can neither pull A's image nor push into A's repository; A can pull its own.
    engine = docker.from_env()
    repo = f"{ch.registry}/{view['image']}"
    with pytest.raises(docker.errors.APIError, match="denied|unauthorized|not found"):
        engine.images.pull(repo, auth_config={"username": "team-b",
                                              "password": ch.tokens["team-b"]})
    local.tag(f"{ch.registry}/teams/team-a/intruder", "v1")
    try:
        lines = list(engine.images.push(f"{ch.registry}/teams/team-a/intruder", "v1",
                                        stream=True, decode=True,
                                        auth_config={"username": "team-b",
                                                     "password": ch.tokens["team-b"]}))
        assert any("denied" in str(ln.get("error", "")) or "unauthorized"
                   in str(ln.get("error", "")) for ln in lines), lines
    finally:
        engine.images.remove(f"{ch.registry}/teams/team-a/intruder:v1", noprune=True)
    pulled = engine.images.pull(repo, auth_config={"username": "team-a",
                                                   "password": ch.tokens["team-a"]})
    assert pulled.id == local.id
    engine.images.remove(repo, noprune=True)

    # Submitting another team's repository, or an image never pushed.
    other = _one_line(ch.eagc("submit", "teams/team-b/sanity-agent:latest", team="team-a"))
    assert "not team team-a's repository" in other
    never = _one_line(ch.eagc("submit", "teams/team-b/nothing:v1", team="team-b"))
    assert "no image teams/team-b/nothing:v1" in never and "push it first" in never
    # Team A's one submission at a time waits: the quota says so before the registry.
    busy = _one_line(ch.eagc("submit", "teams/team-a/nothing:v1", team="team-a"))
    assert "quota: 1 of your submissions wait or run" in busy

    # Tokens: a replaced one says it was revoked and when; a wrong one says so.
    old = ch.tokens["team-a"]
    ch.token("team-a")
    env = {**ch.env("team-a"), "EAGC_CHANNEL_TOKEN": old}
    revoked = subprocess.run([sys.executable, "-m", "orchestrator.cli", "submissions"],
                             env=env, capture_output=True, text=True, timeout=60)
    assert "this token was revoked on" in _one_line(revoked)
    env["EAGC_CHANNEL_TOKEN"] = "eagc_made-up"
    wrong = subprocess.run([sys.executable, "-m", "orchestrator.cli", "submissions"],
                           env=env, capture_output=True, text=True, timeout=60)
    assert "not one the channel issued" in _one_line(wrong)


def test_bad_requests_are_refused_in_one_line(channel_only: Served) -> None:
    ch = channel_only
    token = ch.token("team-a")
    auth = {"Authorization": f"Bearer {token}"}
    big = requests.post(ch.url + "/api/v1/submissions", headers=auth,
                        data=b"x" * (300 * 1024), timeout=10)
    assert big.status_code == 413 and "over 256 KiB" in big.json()["detail"]
    # Chunked, with no length to refuse it by: cut off as soon as it passes the cap.
    chunks = (b"y" * 65536 for _ in range(64))  # 4 MiB, never all in memory
    chunked = requests.post(ch.url + "/api/v1/submissions", headers=auth, data=chunks,
                            timeout=30)
    assert chunked.status_code == 413 and "over 256 KiB" in chunked.json()["detail"]
    bad = requests.post(ch.url + "/api/v1/submissions", headers=auth,
                        json={"image": 3, "extra": 1}, timeout=10)
    assert bad.status_code == 422 and bad.json()["detail"].startswith("malformed request")
    anon = requests.get(ch.url + "/api/v1/submissions", timeout=10)
    assert anon.status_code == 401 and "log in first" in anon.json()["detail"]
    runner = requests.post(ch.url + "/api/v1/runner/claim", headers=auth,
                           json={"runner": "x", "kind": "run"}, timeout=10)
    assert runner.status_code == 401  # a team's token is not the runner's
    # Names with path tricks never reach the registry as another team's repository.
    for trick in ("teams/team-a/../team-b/x:v1", "teams/team-a/%2e%2e/x", "../etc/passwd",
                  "teams/TEAM-A/x", "teams/team-a//x", "127.0.0.1:1/teams/team-a/x"):
        r = requests.post(ch.url + "/api/v1/submissions", headers=auth,
                          json={"image": trick}, timeout=10)
        assert r.status_code == 400, (trick, r.text)
        assert "is not an image of the channel's registry" in r.json()["detail"]
    sneaky = requests.get(ch.url + "/api/v1/submissions/..%2F..%2Fchannel.sqlite",
                          headers=auth, timeout=10)
    assert sneaky.status_code == 404
    cancel = requests.post(ch.url + "/api/v1/submissions/s-0000000000/cancel",
                           headers=auth, timeout=10)
    assert cancel.status_code == 404
    # Each refusal is kept: who asked what, and why.
    log = ch.eagc("challenge", "log", "--data", str(ch.data), "--refusals", "50")
    assert log.returncode == 0, log.stderr
    assert "refused 413 POST /api/v1/submissions" in log.stdout
    assert "refused 401 POST /api/v1/runner/claim" in log.stdout
    assert "'teams/team-a/../team-b/x:v1' is not an image" in log.stdout


def _wait_final(ch: Served, team: str, sid: str, timeout: float = 600) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while True:
        out = ch.eagc("submissions", sid, "--json", team=team)
        assert out.returncode == 0, out.stderr
        view: dict[str, Any] = json.loads(out.stdout)
        if view["state"] in ("scored", "failed", "cancelled"):
            return view
        assert time.monotonic() < deadline, (view, (ch.data / "runner.log").read_text())
        time.sleep(2)


@pytest.mark.slow
def test_a_team_pushes_submits_and_watches_it_score(channel: Served) -> None:
    ch = channel
    ch.login("team-a")
    ch.login("team-b")
    a = json.loads(ch.eagc("submit", SANITY, "--json", team="team-a").stdout)
    b = json.loads(ch.eagc("submit", CRASH, "--json", team="team-b").stdout)

    # Team B's image crashes: its free pre-flight says which check failed, and it never
    # reaches the queue.
    crashed = _wait_final(ch, "team-b", b["id"])
    assert crashed["state"] == "failed", crashed
    assert crashed["reason"].startswith("pre-flight: "), crashed["reason"]
    assert "running" not in [h["state"] for h in crashed["history"]]

    follow = ch.eagc("submissions", a["id"], "--follow", team="team-a", timeout=600)
    assert follow.returncode == 0, follow.stderr
    seen = follow.stdout
    # --follow polls every 2 s: it shows the states it catches (a short queue can pass
    # unseen); the history below holds every one.
    assert " scored " in seen.splitlines()[-1], seen  # it follows until the end
    assert max(len(line) for line in seen.splitlines()) <= 80, seen
    view = _wait_final(ch, "team-a", a["id"])
    assert view["state"] == "scored", view
    assert [h["state"] for h in view["history"]][:4] == ["received", "preflight", "queued",
                                                        "running"]
    assert view["preflight"].startswith("passed: one standard episode")
    assert view["image_id"] == docker.from_env().images.get(SANITY).id
    assert view["episodes_done"] == view["episodes_planned"] == 4
    assert view["final_low"] <= view["final"] <= view["final_high"]
    for s in view["splits"]:
        assert s["low"] <= s["score"] <= s["high"]
        assert len(s["verdicts"]) == s["episodes"] == 2
        assert not s["public"] and s["scores"] is None  # hidden: no per-episode score
    text = json.dumps(view)
    assert "seed" not in text.replace("seed 1)", "")  # the pre-flight's public seed only

    board = requests.get(ch.url + "/api/v1/board", timeout=30,
                         headers={"Authorization": f"Bearer {ch.tokens['team-a']}"}).json()
    assert [r["team"] for r in board["rows"]] == ["team-a"]
    assert board["rows"][0]["final"] == pytest.approx(view["final"])
