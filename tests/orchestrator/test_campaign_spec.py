"""Campaign files: validation naming the file and field; images pinned by ID, from archives."""

from __future__ import annotations

import secrets
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from test_campaign_helpers import build_campaign_images

from orchestrator._campaign.driver_io import CampaignError
from orchestrator._campaign.fanout import EpisodeJob, _ensure_image, pin_images
from orchestrator._campaign.spec import load_campaign, plan
from orchestrator._episode.worker import EpisodeSpec
from orchestrator._runtimes.interface import InfraError
from schemas import SchemaError

REPO = Path(__file__).resolve().parents[2]


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "campaign.yaml"
    p.write_text(text)
    return p


GOOD = """
name: q1
track: sanity
phase: local
splits:
  - {name: standard, weight: 0.6, episodes: 2}
  - {name: challenge, weight: 0.4, episodes: 1}
submissions:
  - {team: alpha, image: "eagc/sanity-agent:latest"}
  - {team: beta, image: "eagc-test/crash:latest", archive: beta.tar}
output: /tmp/eagc-q1
"""


def test_example_campaign_is_valid() -> None:
    spec = load_campaign(REPO / "examples" / "campaigns" / "sanity_local.yaml")
    assert spec.track == "sanity" and spec.phase == "local"
    assert [s.weight for s in spec.splits] == [0.6, 0.4]


def test_a_campaign_may_name_a_public_extra_split(tmp_path: Path) -> None:
    """Splits outside the final score (Track 1's dev and vision, Track 2's dev) are named
    without parameters of their own, like the scored ones."""
    text = ("name: extra-splits\ntrack: track1\nphase: local\n"
            "splits:\n  - {name: vision, weight: 1.0, episodes: 1}\n"
            "  - {name: dev, weight: 0.5, episodes: 1}\n"
            "submissions:\n  - {team: a, image: x}\n")
    spec = load_campaign(_write(tmp_path, text))
    assert [s.name for s in spec.splits] == ["vision", "dev"]


def test_relative_archive_is_resolved_against_the_file(tmp_path: Path) -> None:
    (tmp_path / "beta.tar").write_bytes(b"")
    spec = load_campaign(_write(tmp_path, GOOD))
    assert spec.submissions[1].archive == (tmp_path / "beta.tar").resolve()
    keys = plan(spec)
    assert len(keys) == 6 and [k.submission for k in keys[:2]] == ["alpha", "beta"]


@pytest.mark.parametrize("text, where", [
    ("name: q1\ntrack: sanity\n", "splits: Field required"),
    (GOOD.replace("episodes: 2", "episodes: -1"), "splits.0.episodes"),
    (GOOD.replace("phase: local", "phase: final"), "needs a secret location"),
    (GOOD.replace("phase: local", "phase: final\nsecret: hunter2"), "secret:"),
    (GOOD.replace("team: alpha", "team: beta"), "duplicate team names"),
    (GOOD.replace("track: sanity", "track: sanityy"), "Did you mean 'sanity'"),
    (GOOD.replace("name: standard", "name: easy"), "splits.0.name: track 'sanity' has no split"),
    (GOOD, "submissions.1.archive: no such file"),
    (GOOD + "runtime: local\nphase: final\nsecret: env:X\n", "phase"),
    ("name: [unclosed\n", "not valid YAML"),
    ("- a list\n", "a campaign file is a mapping"),
])
def test_bad_campaign_names_file_and_field(tmp_path: Path, text: str, where: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(SchemaError) as e:
        load_campaign(path)
    assert str(path) in str(e.value) and where in str(e.value)


def test_too_long_output_is_refused(tmp_path: Path) -> None:
    (tmp_path / "beta.tar").write_bytes(b"")
    text = GOOD.replace("/tmp/eagc-q1", "/tmp/" + "x" * 80)
    with pytest.raises(SchemaError, match="too long for the episodes' unix sockets"):
        load_campaign(_write(tmp_path, text))


# ---------------------------------------------------------------------------- images
@pytest.fixture()
def scratch_archive(docker_engine: Any, tmp_path: Path) -> Iterator[tuple[str, str, Path]]:
    """A tiny image (FROM scratch) saved to an archive and removed from the engine."""
    ctx = tmp_path / "ctx"
    ctx.mkdir()
    (ctx / "hello.txt").write_text("hello")
    tag = f"eagc-test/scratch:{secrets.token_hex(4)}"
    (ctx / "Dockerfile").write_text(f"FROM scratch\nCOPY hello.txt /\nLABEL nonce={tag}\n")
    image, _ = docker_engine.images.build(path=str(ctx), tag=tag, network_mode="none", rm=True)
    archive = tmp_path / "image.tar"
    with archive.open("wb") as f:
        for chunk in image.save(named=True):
            f.write(chunk)
    docker_engine.images.remove(image.id, force=True)
    yield tag, str(image.id), archive
    try:
        docker_engine.images.remove(image.id, force=True)
    except Exception:  # noqa: BLE001
        pass


def _spec_with(tmp_path: Path, sub: str, phase: str = "local") -> Any:
    text = (f"name: img\ntrack: sanity\nphase: {phase}\nsecret: env:X\n"
            "splits: [{name: standard, episodes: 1}]\n"
            f"submissions:\n  - {sub}\noutput: /tmp/eagc-img\n")
    return load_campaign(_write(tmp_path, text))


@pytest.mark.docker
def test_archive_is_loaded_and_digest_checked(docker_engine: Any, tmp_path: Path,
                                              scratch_archive: tuple[str, str, Path]) -> None:
    tag, digest, archive = scratch_archive
    spec = _spec_with(tmp_path, f"{{team: t, image: '{tag}', digest: '{digest}', "
                                f"archive: '{archive}'}}", phase="final")
    pinned = pin_images(spec, docker_engine)["t"]
    assert pinned.run == digest and pinned.digest == digest
    assert docker_engine.images.get(digest).id == digest  # loaded from the archive

    wrong = "sha256:" + "1" * 64
    spec = _spec_with(tmp_path, f"{{team: t, image: '{tag}', digest: '{wrong}', "
                                f"archive: '{archive}'}}", phase="final")
    with pytest.raises(CampaignError, match="its archive does not hold it"):
        pin_images(spec, docker_engine)


@pytest.mark.docker
def test_unpinned_images(docker_engine: Any, tmp_path: Path) -> None:
    build_campaign_images(docker_engine, "crash")
    spec = _spec_with(tmp_path, "{team: t, image: 'eagc-test/crash:latest'}")
    pinned = pin_images(spec, docker_engine)["t"]  # a local campaign pins the current ID
    assert pinned.run == docker_engine.images.get("eagc-test/crash:latest").id
    spec = _spec_with(tmp_path, "{team: t, image: 'eagc-test/crash:latest'}", phase="final")
    with pytest.raises(CampaignError, match="runs pinned images only"):
        pin_images(spec, docker_engine)
    spec = _spec_with(tmp_path, "{team: t, image: 'eagc-test/nothing-here:latest'}")
    with pytest.raises(CampaignError, match="is not loaded here"):
        pin_images(spec, docker_engine)


@pytest.mark.docker
def test_node_loads_the_archive_from_the_object_store(
        docker_engine: Any, scratch_archive: tuple[str, str, Path]) -> None:
    """What a task does on a node without the image: load it from the driver's copy."""
    import ray

    tag, digest, archive = scratch_archive
    ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False)
    try:
        ref = ray.put(archive.read_bytes())

        def job(d: str) -> EpisodeJob:
            spec = EpisodeSpec(track="sanity", image=tag, seed=1, runs_dir=Path("/tmp"),
                               episode="ep0", index=0)
            return EpisodeJob(campaign="c", submission="t", retry=0, spec=spec, digest=d,
                              archive=[ref])

        assert _ensure_image(docker_engine, job(digest)) == digest
        assert docker_engine.images.get(digest).id == digest
        with pytest.raises(InfraError, match="does not hold the pinned image"):
            _ensure_image(docker_engine, job("sha256:" + "2" * 64))
    finally:
        ray.shutdown()
