"""Hidden episode seeds, their published commitment, and the reveal.

The seed of episode ``index`` of ``split`` in ``campaign`` is::

    int.from_bytes(HMAC-SHA256(secret, f"{campaign}/{split}/{index}")[:8], "big") >> 1

a 63-bit non-negative integer (too many to search for the one behind a scenario the agent
sees). Seeds live in the driver's memory and in the Ray task arguments only: they are never
written to the results store, to an episode's ``output``/``input``/``sock`` folders or to the
agent's environment. Organizer-only files (the episode's MCAP in ``host/``) record them for
replay.

Before a campaign, organizers publish the **commitment**: the SHA-256 of the seed list, one
line per episode, ``{campaign}/{split}/{index} {seed}\\n``, in campaign order. After it they
publish the list (``eagc campaign reveal``) and anyone can check it against the commitment.

The secret comes from ``secret: env:NAME`` or ``secret: file:/path`` in the campaign file.
A ``local`` campaign may have none: its seeds then derive from the campaign name, which is
public, so anyone can recompute them. That is fine for a team's own tests and never for an
official run (the schema refuses a non-local campaign without a secret).
"""

from __future__ import annotations

import hashlib
import hmac
import os
from dataclasses import dataclass
from pathlib import Path

from orchestrator._errors import OrchestratorError
from schemas import CampaignSpec

PUBLIC_PREFIX = b"eagc-public-local-seeds/"


class SeedError(OrchestratorError, ValueError):
    """Raised when the seed secret cannot be read, or a revealed list does not match."""


@dataclass(frozen=True)
class Secret:
    """The seed secret and where it came from (``public`` when derived from the name)."""

    key: bytes
    source: str
    public: bool


@dataclass(frozen=True)
class SeededEpisode:
    split: str
    index: int
    seed: int

    def line(self, campaign: str) -> str:
        return f"{campaign}/{self.split}/{self.index} {self.seed}\n"


def load_secret(spec: CampaignSpec) -> Secret:
    """Reads the secret named by ``spec.secret``; derives a public one for a local campaign."""
    where = spec.secret
    if where is None:
        if spec.phase != "local":  # the schema refuses this too; belt and braces
            raise SeedError(f"campaign {spec.name!r} ({spec.phase}) has no secret location")
        return Secret(PUBLIC_PREFIX + spec.name.encode(), "campaign name (PUBLIC)", True)
    kind, _, ref = where.partition(":")
    if kind == "env":
        value = os.environ.get(ref)
        if not value:
            raise SeedError(
                f"campaign {spec.name!r}: the seed secret should be in the environment "
                f"variable {ref!r}, which is unset or empty. Set it (e.g. `export "
                f"{ref}=$(openssl rand -hex 32)`) and keep it away from the teams."
            )
        return Secret(value.encode(), f"env:{ref}", False)
    if kind == "file":
        path = Path(ref)
        try:
            value_b = path.read_bytes().strip()
        except OSError as e:
            raise SeedError(
                f"campaign {spec.name!r}: cannot read the seed secret file {path}: "
                f"{e.strerror or e}"
            ) from e
        if not value_b:
            raise SeedError(f"campaign {spec.name!r}: the seed secret file {path} is empty")
        if path.stat().st_mode & 0o077:
            # Not fatal: some deployments mount secrets world-readable inside a pod.
            import logging

            logging.getLogger("eagc.seeds").warning(
                "the seed secret file %s is readable by group or others (chmod 600 it)", path
            )
        return Secret(value_b, f"file:{path}", False)
    raise SeedError(f"secret must be 'env:NAME' or 'file:/path', got {where!r}")


def episode_seed(key: bytes, campaign: str, split: str, index: int) -> int:
    """``HMAC-SHA256(key, "campaign/split/index")`` as a 63-bit non-negative integer."""
    digest = hmac.new(key, f"{campaign}/{split}/{index}".encode(), hashlib.sha256).digest()
    return int.from_bytes(digest[:8], "big") >> 1


def seed_list(spec: CampaignSpec, secret: Secret) -> list[SeededEpisode]:
    """Every episode's seed, in campaign order (splits as written, then index)."""
    return [
        SeededEpisode(split.name, i, episode_seed(secret.key, spec.name, split.name, i))
        for split in spec.splits
        for i in range(split.episodes)
    ]


def commitment(spec: CampaignSpec, seeds: list[SeededEpisode]) -> str:
    """SHA-256 (hex) of the seed list, one ``campaign/split/index seed`` line per episode."""
    h = hashlib.sha256()
    for s in seeds:
        h.update(s.line(spec.name).encode())
    return h.hexdigest()


def revealed_text(spec: CampaignSpec, seeds: list[SeededEpisode]) -> str:
    """The exact text whose SHA-256 is the commitment (what ``reveal`` publishes)."""
    return "".join(s.line(spec.name) for s in seeds)


def check_reveal(text: str, expected: str) -> bool:
    """True when a published seed list hashes to the published commitment."""
    return hmac.compare_digest(hashlib.sha256(text.encode()).hexdigest(), expected.strip())
