"""A finalist freezes through the channel's API, as `eagc freeze` does: uploads its report
and statement, freezes, reads back what is kept; the refusals (not a finalist, a name the
final does not take, a body over the cap, after the deadline) are one line each; the
calendar page shows the key that signs the manifest before the final, and it is the key
the manifest verifies with. A real channel database on an injected clock, served by
uvicorn in a thread (no registry, no Docker)."""

from __future__ import annotations

import hashlib
import json
import secrets
import sys
import time
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path

import pytest
import requests

from orchestrator._channel.api import create_app
from orchestrator._channel.channel import Channel
from orchestrator._channel.client import Login, freeze
from orchestrator._channel.db import ChannelError, Clock
from orchestrator._channel.final import MAX_FILE_BYTES, verify, write_manifest
from orchestrator._channel.registry import RegistryProcess
from schemas import ChallengeSpec, Outcome, SubmitRequest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _served import serve_app  # noqa: E402

T0 = datetime(2026, 9, 1, 12, 0, tzinfo=UTC).timestamp()
DISCLOSURE = json.dumps({
    "version": "eagc-disclosure/v1", "data": [], "pretrained_models": [],
    "compute": {"description": "none: no learned parameters"}, "dependencies": []})


class Served:
    def __init__(self, channel: Channel, url: str) -> None:
        self.channel, self.url = channel, url
        self.tokens = {t: channel.db.new_token(t, days=30)[0]
                       for t in ("team-a", "team-b", "team-c")}

    def login(self, team: str) -> Login:
        return Login(self.url, team, self.tokens[team])

    def put(self, team: str, name: str, data: object) -> requests.Response:
        return requests.put(f"{self.url}/api/v1/final/files/{name}", data=data, timeout=60,
                            headers={"Authorization": f"Bearer {self.tokens[team]}"})


@pytest.fixture()
def served(tmp_path: Path) -> Iterator[Served]:
    spec = ChallengeSpec.model_validate({
        "name": "finale", "track": "sanity", "teams": ["team-a", "team-b", "team-c"],
        "phases": [{"name": "final", "kind": "final", "who": "finalists",
                    "closes": "start+2d", "splits": [{"name": "standard", "episodes": 2}]}]})
    ch = Channel(spec, tmp_path / "data", clock=Clock(origin=T0, speed=0.0))
    ch.add_spec_teams()
    ch.registry = RegistryProcess(tmp_path / "registry", ch.keys, realm="http://unused",
                                  port=5999)
    ch.set_finalists(ch.phase("final"), ["team-a", "team-b"], who="test", why="the cut")
    try:
        with serve_app(create_app(ch), "freeze-api") as url:
            yield Served(ch, url)
    finally:
        ch.db.close()


def _queued(ch: Channel, team: str) -> str:
    """A submission of ``team`` past its pre-flight."""
    sid = ch.accept(team, ch.open_phase(), f"teams/{team}/agent",
                    "sha256:" + secrets.token_hex(32),
                    SubmitRequest(image="x", disclosure=DISCLOSURE)).id
    work = ch.claim("r", "preflight")
    assert work is not None and work.id == sid
    ch.report(sid, Outcome(runner="r", kind="preflight", ok=True,
                           image_id="sha256:" + secrets.token_hex(32)))
    return sid


def test_a_finalist_freezes_over_the_api_and_the_manifest_names_its_files(
        served: Served, tmp_path: Path) -> None:
    ch = served.channel
    report = tmp_path / "report.md"
    report.write_text("# Our technical report\n\nHow the agent builds its world model.\n")
    statement = tmp_path / "open.yaml"
    statement.write_text("released: true\nurl: https://example.org/agent\nlicense: MIT\n")
    sid = _queued(ch, "team-a")
    got = freeze(sid, report, served.login("team-a"), statement=statement)
    assert got["submission"] == sid and got["phase"] == "final"
    assert got["files"]["report"]["sha256"] == hashlib.sha256(report.read_bytes()).hexdigest()
    assert set(got["files"]) == {"disclosure", "report", "statement"}
    assert not (ch.data / "final" / ".uploads" / "team-a").exists()  # uploads consumed
    mine = requests.get(f"{served.url}/api/v1/final", timeout=10, headers={
        "Authorization": f"Bearer {served.tokens['team-a']}"}).json()
    assert [f["submission"] for f in mine] == [sid]
    theirs = requests.get(f"{served.url}/api/v1/final", timeout=10, headers={
        "Authorization": f"Bearer {served.tokens['team-b']}"}).json()
    assert theirs == []  # another team sees nothing of team-a's freeze

    # The key on the public calendar, before the deadline, is the one that signs.
    page = requests.get(f"{served.url}/calendar", timeout=10).text
    pem = requests.get(f"{served.url}/api/v1/final/key", timeout=10).text
    assert pem.startswith("-----BEGIN PUBLIC KEY-----") and pem.strip() in page
    assert hashlib.sha256(pem.encode()).hexdigest() in page
    (tmp_path / "published.pub").write_text(pem)
    ch.clock.origin += 2 * 86400 + 1
    written = write_manifest(ch, "final", tmp_path / "public")
    checks = list(verify(written.manifest, key=tmp_path / "published.pub"))
    assert all(c.ok for c in checks), checks
    doc = json.loads(written.manifest.read_bytes())
    assert doc["finalists"][0]["files"]["report"]["sha256"] == got["files"]["report"]["sha256"]

    # After the deadline: no upload, no freeze, each refusal one line.
    late = served.put("team-a", "report.md", b"# late\n")
    assert late.status_code == 403 and "deadline passed" in late.json()["detail"]
    with pytest.raises(ChannelError, match="deadline passed"):
        freeze(sid, report, served.login("team-a"))


def test_the_freezes_refusals_are_one_line_each(served: Served, tmp_path: Path) -> None:
    ch = served.channel
    report = tmp_path / "report.md"
    report.write_text("# report\n")
    outsider = served.put("team-c", "report.md", b"# report\n")  # the cut left it out
    assert outsider.status_code == 403
    assert outsider.json()["detail"] == "team team-c is not a finalist of final"
    bad = served.put("team-a", "report.docx", b"x")
    assert bad.status_code == 404
    assert bad.json()["detail"].startswith("upload one of report.pdf, report.md")
    with pytest.raises(ChannelError, match=r"a report is \.markdown, \.md, \.pdf, not \.txt"):
        freeze("any", tmp_path / "report.txt", served.login("team-a"))
    # Nothing uploaded yet: the freeze says what to do.
    sid = _queued(ch, "team-a")
    r = requests.post(f"{served.url}/api/v1/final/freeze", json={"submission": sid},
                      headers={"Authorization": f"Bearer {served.tokens['team-a']}"},
                      timeout=10)
    assert r.status_code == 409 and "no technical report uploaded" in r.json()["detail"]
    # A PDF that is not one: refused by what it is, not its name.
    assert served.put("team-a", "report.pdf", b"<html>not a pdf</html>").status_code == 201
    r = requests.post(f"{served.url}/api/v1/final/freeze", json={"submission": sid},
                      headers={"Authorization": f"Bearer {served.tokens['team-a']}"},
                      timeout=10)
    assert r.status_code == 400 and "is named .pdf but is not a PDF" in r.json()["detail"]
    # Over the cap, streamed without a length: cut off at the cap, nothing kept.
    chunk = b"%" * 2**20

    def body() -> Iterator[bytes]:
        for _ in range(MAX_FILE_BYTES // len(chunk) + 2):
            yield chunk

    try:
        big = served.put("team-b", "report.md", body())
    except requests.ConnectionError:
        big = None  # the server may close before the client has sent it all
    if big is not None:
        assert big.status_code == 413 and big.json()["detail"] == "request body over 50 MiB"
    uploads = ch.data / "final" / ".uploads" / "team-b"
    for _ in range(50):  # the handler removes its part file once it sees the cut
        if not uploads.exists() or not any(uploads.iterdir()):
            break
        time.sleep(0.1)
    assert not uploads.exists() or not any(uploads.iterdir()), list(uploads.iterdir())
    # Every other route keeps its small cap.
    r = requests.post(f"{served.url}/api/v1/submissions", data=b"{" + b" " * 300_000 + b"}",
                      headers={"Authorization": f"Bearer {served.tokens['team-a']}",
                               "Content-Type": "application/json"}, timeout=10)
    assert r.status_code == 413 and r.json()["detail"] == "request body over 256 KiB"
