"""Hidden seeds: HMAC derivation, secret sources, the commitment and its reveal."""

from __future__ import annotations

import hashlib
import hmac
from pathlib import Path

import pytest

from orchestrator._campaign.seeds import (
    SeedError,
    check_reveal,
    commitment,
    episode_seed,
    load_secret,
    revealed_text,
    seed_list,
)
from schemas import CampaignSpec


def _spec(**kw: object) -> CampaignSpec:
    base: dict[str, object] = {
        "name": "final-2026", "track": "sanity", "phase": "final", "secret": "env:EAGC_T_SECRET",
        "splits": [{"name": "standard", "episodes": 3}, {"name": "challenge", "episodes": 2}],
        "submissions": [{"team": "a", "image": "x", "digest": "sha256:" + "0" * 64}],
    }
    return CampaignSpec.model_validate({**base, **kw})


def test_seed_is_hmac_sha256_of_campaign_split_index() -> None:
    digest = hmac.new(b"k", b"c/standard/4", hashlib.sha256).digest()
    assert episode_seed(b"k", "c", "standard", 4) == int.from_bytes(digest[:8], "big") >> 1
    seeds = {episode_seed(b"k", "c", s, i) for s in ("standard", "challenge") for i in range(50)}
    assert len(seeds) == 100 and all(0 <= s < 2**63 for s in seeds)
    assert episode_seed(b"k2", "c", "standard", 4) != episode_seed(b"k", "c", "standard", 4)


def test_secret_from_env_and_file(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("EAGC_T_SECRET", "s3cret")
    spec = _spec()
    env = load_secret(spec)
    assert env.key == b"s3cret" and not env.public and env.source == "env:EAGC_T_SECRET"
    f = tmp_path / "secret"
    f.write_text("s3cret\n")
    f.chmod(0o600)
    from_file = load_secret(_spec(secret=f"file:{f}"))
    assert from_file.key == b"s3cret"
    assert seed_list(spec, env) == seed_list(spec, from_file)


def test_missing_secret_is_a_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("EAGC_T_SECRET", raising=False)
    with pytest.raises(SeedError, match="EAGC_T_SECRET"):
        load_secret(_spec())
    with pytest.raises(SeedError, match="cannot read"):
        load_secret(_spec(secret="file:/nonexistent/secret"))


def test_local_campaign_without_secret_is_public_and_says_so() -> None:
    spec = _spec(phase="local", secret=None)
    secret = load_secret(spec)
    assert secret.public and "PUBLIC" in secret.source
    assert seed_list(spec, secret) == seed_list(spec, load_secret(spec))


def test_commitment_and_reveal(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("EAGC_T_SECRET", "s3cret")
    spec = _spec()
    seeds = seed_list(spec, load_secret(spec))
    assert [(s.split, s.index) for s in seeds] == [
        ("standard", 0), ("standard", 1), ("standard", 2), ("challenge", 0), ("challenge", 1)]
    published = commitment(spec, seeds)
    text = revealed_text(spec, seeds)
    assert text.splitlines()[0] == f"final-2026/standard/0 {seeds[0].seed}"
    assert check_reveal(text, published)
    tampered = text.replace(str(seeds[1].seed), str(seeds[1].seed + 1))
    assert not check_reveal(tampered, published)
    monkeypatch.setenv("EAGC_T_SECRET", "other")
    assert commitment(spec, seed_list(spec, load_secret(spec))) != published
