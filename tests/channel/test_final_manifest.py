"""The frozen final on the channel's real database, its clock injected (no registry, no
Docker): two finalists freeze, the channel signs the manifest at the deadline, and
``verify`` holds on it and fails, naming what, on a changed byte, another key's signature
or a campaign whose results ran other images."""

from __future__ import annotations

import base64
import json
import secrets
import time
from datetime import UTC, datetime
from pathlib import Path

import pytest
from typer.testing import CliRunner

from orchestrator._campaign.spec import load_campaign
from orchestrator._channel.channel import Channel
from orchestrator._channel.db import ChannelError, Clock
from orchestrator._channel.final import (
    freeze,
    manifest_campaign,
    verify,
    write_manifest,
)
from orchestrator._channel.registry import RegistryProcess
from orchestrator._results.store import EpisodeKey, ResultsStore
from orchestrator.cli.main import app
from schemas import (
    ChallengeSpec,
    EpisodeResult,
    EpisodeStats,
    EpisodeStatus,
    Outcome,
    ScoreCard,
    SubmitRequest,
)

T0 = datetime(2026, 9, 1, 12, 0, tzinfo=UTC).timestamp()
DISCLOSURE = json.dumps({
    "version": "eagc-disclosure/v1", "data": [], "pretrained_models": [],
    "compute": {"description": "none: no learned parameters"}, "dependencies": []})


@pytest.fixture()
def channel(tmp_path: Path) -> Channel:
    spec = ChallengeSpec.model_validate({
        "name": "finale", "track": "sanity", "teams": ["team-a", "team-b"],
        "phases": [{"name": "final", "kind": "final", "closes": "start+2d",
                    "splits": [{"name": "standard", "episodes": 2}]}]})
    ch = Channel(spec, tmp_path / "data", clock=Clock(origin=T0, speed=0.0))
    ch.add_spec_teams()
    ch.registry = RegistryProcess(tmp_path / "registry", ch.keys, realm="http://unused",
                                  port=5999)
    return ch


def _queued(ch: Channel, team: str) -> tuple[str, str]:
    """A submission of ``team`` past its pre-flight; returns it and its image ID."""
    sid = ch.accept(team, ch.open_phase(), f"teams/{team}/agent",
                    "sha256:" + secrets.token_hex(32),
                    SubmitRequest(image="x", disclosure=DISCLOSURE)).id
    image_id = "sha256:" + secrets.token_hex(32)
    work = ch.claim("r", "preflight")
    assert work is not None and work.id == sid
    ch.report(sid, Outcome(runner="r", kind="preflight", ok=True, image_id=image_id))
    return sid, image_id


def _files(tmp_path: Path, team: str) -> tuple[Path, Path]:
    report = tmp_path / f"{team}-report.md"
    report.write_text(f"# {team}'s technical report\n\nHow the agent works.\n")
    statement = tmp_path / f"{team}-statement.yaml"
    statement.write_text("released: true\nurl: https://example.org/agent\nlicense: MIT\n")
    return report, statement


def _frozen_final(ch: Channel, tmp_path: Path) -> tuple[Path, dict[str, str]]:
    """Both teams freeze, the deadline passes, the manifest is written; returns its path
    and each team's image ID."""
    images = {}
    for team in ("team-a", "team-b"):
        sid, images[team] = _queued(ch, team)
        report, statement = _files(tmp_path, team)
        freeze(ch, team, sid, report, statement if team == "team-a" else None)
    ch.clock.origin += 2 * 86400 + 1
    written = write_manifest(ch, "final", tmp_path / "public")
    return written.manifest, images


def test_two_finalists_freeze_and_the_signed_manifest_verifies(channel: Channel,
                                                                 tmp_path: Path) -> None:
    manifest, images = _frozen_final(channel, tmp_path)
    doc = json.loads(manifest.read_bytes())
    assert manifest.read_bytes() == json.dumps(doc, sort_keys=True,
                                               separators=(",", ":")).encode()
    assert [f["team"] for f in doc["finalists"]] == ["team-a", "team-b"]
    assert set(doc["finalists"][0]["files"]) == {"disclosure", "report", "statement"}
    assert set(doc["finalists"][1]["files"]) == {"disclosure", "report"}
    assert len(doc["eagc"]["code_version"]) == 16 and doc["eagc"]["version"]
    assert len(doc["seed_commitment"]) == 64
    assert (channel.data / "keys" / "manifest.ed25519").stat().st_mode & 0o777 == 0o600
    assert (channel.data / "keys" / "manifest.pub").read_bytes().startswith(b"-----BEGIN")
    checks = list(verify(manifest))
    assert all(c.ok for c in checks), checks
    assert [c.name for c in checks][:1] == ["signature"] and len(checks) == 1 + 5
    # The campaign the runner reads: exactly the frozen images, pinned by image ID.
    spec = load_campaign(manifest.parent / "campaign.yaml")
    assert spec.phase == "final" and spec.name == "finale-final"
    assert {s.team: s.digest for s in spec.submissions} == images
    assert all(s.disclosure is not None and s.disclosure.is_file() for s in spec.submissions)
    assert manifest_campaign(doc).submissions[0].image.startswith("teams/team-a/agent@sha256:")
    # Written again: the same bytes (the first signing is kept).
    again = write_manifest(channel, "final", tmp_path / "again")
    assert again.manifest.read_bytes() == manifest.read_bytes()
    result = CliRunner().invoke(app, ["challenge", "verify", str(manifest)])
    assert result.exit_code == 0, result.output
    assert "FAIL" not in result.output and "ok    signature" in result.output


def test_one_changed_byte_fails_naming_the_file(channel: Channel, tmp_path: Path) -> None:
    manifest, _ = _frozen_final(channel, tmp_path)
    report = manifest.parent / "team-b" / "report.md"
    data = bytearray(report.read_bytes())
    data[3] ^= 0x01
    report.write_bytes(bytes(data))
    failed = [c for c in verify(manifest) if not c.ok]
    assert [c.name for c in failed] == ["file team-b/report.md"]
    result = CliRunner().invoke(app, ["challenge", "verify", str(manifest)])
    assert result.exit_code == 1
    assert "FAIL  file team-b/report.md" in result.output


def test_a_signature_by_another_key_fails(channel: Channel, tmp_path: Path) -> None:
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

    manifest, _ = _frozen_final(channel, tmp_path)
    other = Ed25519PrivateKey.generate()
    pem = other.public_key().public_bytes(serialization.Encoding.PEM,
                                          serialization.PublicFormat.SubjectPublicKeyInfo)
    (tmp_path / "other.pub").write_bytes(pem)
    # The channel's signature, checked against another key.
    (check,) = verify(manifest, key=tmp_path / "other.pub")
    assert check.name == "signature" and not check.ok
    # Another key's signature, checked against the channel's.
    sig = manifest.with_suffix(".sig")
    sig.write_bytes(base64.b64encode(other.sign(manifest.read_bytes())))
    (check,) = verify(manifest, key=channel.data / "keys" / "manifest.pub")
    assert not check.ok
    result = CliRunner().invoke(app, ["challenge", "verify", str(manifest)])
    assert result.exit_code == 1 and "FAIL  signature" in result.output


def test_freezing_is_refused_after_the_deadline_and_for_another_teams_submission(
        channel: Channel, tmp_path: Path) -> None:
    sid, _ = _queued(channel, "team-a")
    report, _ = _files(tmp_path, "team-a")
    with pytest.raises(ChannelError, match="no submission"):
        freeze(channel, "team-b", sid, report)
    with pytest.raises(ChannelError, match="neither PDF"):
        freeze(channel, "team-a", sid, tmp_path / "team-a-statement.yaml")
    with pytest.raises(ChannelError, match="deadline is"):
        write_manifest(channel, "final")  # before the deadline: finalists may still freeze
    first = freeze(channel, "team-a", sid, report)
    assert first.files["report"]["name"] == "team-a/report.md"
    channel.clock.origin += 2 * 86400
    with pytest.raises(ChannelError, match="deadline passed") as e:
        freeze(channel, "team-a", sid, report)
    assert e.value.status == 403


def _result(image: str) -> EpisodeResult:
    now = time.time()
    return EpisodeResult(
        episode="ep" + secrets.token_hex(8), track="sanity", split="standard", image=image,
        runtime="docker", status=EpisodeStatus.COMPLETED,
        score=ScoreCard(track="sanity", total=0.5, components={}, weights={}),
        stats=EpisodeStats(), started_at=now, finished_at=now)


def test_runs_must_have_run_exactly_the_manifest_images(channel: Channel,
                                                        tmp_path: Path) -> None:
    manifest, images = _frozen_final(channel, tmp_path)
    doc = json.loads(manifest.read_bytes())
    spec = manifest_campaign(doc, output=tmp_path / "runs")

    def store(name: str, ran: dict[str, str]) -> Path:
        path = tmp_path / name / "results.sqlite"
        with ResultsStore(path) as s:
            s.register(spec, doc["seed_commitment"], 4)
            for team, image in ran.items():
                for i in range(2):
                    s.commit(spec.name, EpisodeKey(team, "standard", i), _result(image),
                             retry=0, node=None)
        return path.parent

    good = store("good", images)
    kept = good / spec.name / "submissions" / "team-a.json"
    kept.parent.mkdir(parents=True)
    sha = "sha256:" + doc["finalists"][0]["files"]["disclosure"]["sha256"]
    kept.write_text(json.dumps({"team": "team-a", "digest": images["team-a"], "sha256": sha}))
    assert all(c.ok for c in verify(manifest, runs=good))
    # The campaign's record of what it pinned for a team must be the manifest's image too.
    kept.write_text(json.dumps({"team": "team-a", "digest": "sha256:" + "d" * 64}))
    assert [c.name for c in verify(manifest, runs=good) if not c.ok] == ["image team-a"]
    swapped = store("swapped", {**images, "team-b": "sha256:" + "e" * 64})
    failed = [c for c in verify(manifest, runs=swapped) if not c.ok]
    assert [c.name for c in failed] == ["image team-b"]
    assert "sha256:eeeeeeeeeeee" in failed[0].detail
    result = CliRunner().invoke(app, ["challenge", "verify", str(manifest),
                                      "--runs", str(swapped)])
    assert result.exit_code == 1 and "FAIL  image team-b" in result.output


def test_the_commands_on_a_channel_folder(tmp_path: Path) -> None:
    """``eagc challenge freeze|manifest|verify`` on the channel's folder, the wall clock
    three days after the channel started (its final closed a day ago)."""
    spec = ChallengeSpec.model_validate({
        "name": "finale", "track": "sanity", "teams": ["team-a"],
        "phases": [{"name": "final", "kind": "final", "closes": "start+2d",
                    "splits": [{"name": "standard", "episodes": 1}]}]})
    data = tmp_path / "data"
    ch = Channel(spec, data, clock=Clock(origin=float(int(time.time()) - 3 * 86400), speed=0.0))
    ch.add_spec_teams()
    ch.db.set_meta("spec", spec.model_dump_json())  # what `serve` keeps for the commands
    ch.registry = RegistryProcess(tmp_path / "registry", ch.keys, realm="http://unused",
                                  port=5999)
    sid, image_id = _queued(ch, "team-a")
    report, statement = _files(tmp_path, "team-a")
    freeze(ch, "team-a", sid, report, statement)  # on the channel's clock: before the close
    runner = CliRunner()
    late = runner.invoke(app, ["challenge", "freeze", "team-a", sid, "--report", str(report),
                               "--data", str(data)])
    assert late.exit_code == 1 and "deadline passed" in late.output
    out = tmp_path / "pub"
    made = runner.invoke(app, ["challenge", "manifest", "final", "--data", str(data),
                               "--out", str(out)])
    assert made.exit_code == 0, made.output
    assert {p.name for p in out.iterdir()} >= {"manifest.json", "manifest.sig",
                                               "manifest.pub", "campaign.yaml", "team-a"}
    checked = runner.invoke(app, ["challenge", "verify", str(out / "manifest.json"),
                                  "--key", str(data / "keys" / "manifest.pub")])
    assert checked.exit_code == 0, checked.output
    assert image_id in (out / "campaign.yaml").read_text()
