"""The registry's storage with the real registry: a team's cap refuses its pushes, garbage
collection after a phase removes only what no submission names, and a backup taken while
the channel serves holds its submissions."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import docker
import pytest
import requests
from test_channel_e2e import SANITY, Served
from test_channel_faults import _challenge

pytestmark = [pytest.mark.docker]
CRASH = "eagc-test/crash:latest"


def _manifest(ch: Served, repo: str, ref: str) -> int:
    """The registry's answer to a HEAD of ``repo:ref`` as the runner (200 or 404)."""
    from orchestrator._channel.registry import RUNNER, Keys, grant

    keys = Keys(ch.data / "keys")
    token = keys.token(RUNNER, grant(RUNNER, [f"repository:{repo}:pull"]))["token"]
    accept = ("application/vnd.docker.distribution.manifest.v2+json, "
              "application/vnd.oci.image.manifest.v1+json")
    return requests.head(f"http://{ch.registry}/v2/{repo}/manifests/{ref}", timeout=10,
                         headers={"Authorization": f"Bearer {token}", "Accept": accept}
                         ).status_code


def test_gc_keeps_what_submissions_name_and_a_backup_holds_them(
        images: dict[str, str], tmp_path: Path) -> None:
    ch = Served(runner=False)
    data = ch.data
    try:
        ch.login("team-a")
        sub = ch.eagc("submit", SANITY, "--json", team="team-a")
        assert sub.returncode == 0, sub.stderr
        kept = json.loads(sub.stdout)["image"]
        # Pushed, never submitted.
        engine = docker.from_env()
        engine.images.get(CRASH).tag(f"{ch.registry}/teams/team-a/scratch", "v1")
        for line in engine.images.push(f"{ch.registry}/teams/team-a/scratch", "v1",
                                       stream=True, decode=True,
                                       auth_config={"username": "team-a",
                                                    "password": ch.tokens["team-a"]}):
            assert "error" not in line, line
        engine.images.remove(f"{ch.registry}/teams/team-a/scratch:v1", noprune=True)
        assert _manifest(ch, "teams/team-a/scratch", "v1") == 200

        copy = tmp_path / "backup"
        done = ch.eagc("challenge", "backup", "--data", str(data), "--to", str(copy))
        assert done.returncode == 0, done.stderr
        with sqlite3.connect(copy / "channel.sqlite") as db:
            assert db.execute("SELECT COUNT(*) FROM submissions").fetchone()[0] == 1
        assert (copy / "keys" / "token.key").is_file()

        refused = ch.eagc("challenge", "gc", "--data", str(data), "--why", "phase over")
        assert "stop it first" in refused.stderr
        ch.stop(remove=False)
        gc = ch.eagc("challenge", "gc", "--data", str(data), "--why", "phase over")
        assert gc.returncode == 0, gc.stderr
        assert "removed 1 image no submission names" in gc.stdout

        ch = Served(runner=False, data=data)
        repo, _, digest = kept.partition("@")
        assert _manifest(ch, repo, digest) == 200  # the submitted image stays
        assert _manifest(ch, "teams/team-a/scratch", "v1") == 404
        log = ch.eagc("challenge", "log", "--data", str(data))
        assert "gc       1 images: phase over" in log.stdout
    finally:
        ch.stop()


def test_a_team_over_its_storage_cap_cannot_push(images: dict[str, str],
                                                 tmp_path: Path) -> None:
    ch = Served(runner=False, challenge=_challenge(tmp_path, storage_mb_per_team=1))
    try:
        ch.login("team-a")
        first = ch.eagc("submit", SANITY, "--json", team="team-a")
        assert first.returncode == 0, first.stderr  # under the cap when it started
        second = ch.eagc("submit", CRASH, team="team-a")
        assert second.returncode == 1
        assert "of the registry, its cap (1 MB)" in second.stderr
        # The registry itself refuses a push that goes round the client's check.
        engine = docker.from_env()
        engine.images.get(CRASH).tag(f"{ch.registry}/teams/team-a/direct", "v1")
        try:
            lines = list(engine.images.push(
                f"{ch.registry}/teams/team-a/direct", "v1", stream=True, decode=True,
                auth_config={"username": "team-a", "password": ch.tokens["team-a"]}))
        finally:
            engine.images.remove(f"{ch.registry}/teams/team-a/direct:v1", noprune=True)
        assert any("denied" in str(ln.get("error", "")) for ln in lines), lines
    finally:
        ch.stop()
