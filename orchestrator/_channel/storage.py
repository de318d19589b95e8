"""The registry's storage: what each team uses, garbage collection after a phase, and the
channel's backup.

The registry keeps content-addressed blobs (``blobs/sha256/…/data``) and, per repository,
links to the manifests pushed there (``repositories/<repo>/_manifests/revisions/…``) and to
what each tag points at. A team's usage is the size of the distinct blobs its manifests
name. Garbage collection (with the channel stopped: the registry's own tool must not run
beside a registry that accepts pushes) removes every manifest no submission names, as the
registry's DELETE would, then runs ``docker-registry garbage-collect`` for the blobs left
without a manifest.
"""

from __future__ import annotations

import json
import os
import shutil
import sqlite3
import subprocess
from dataclasses import dataclass
from pathlib import Path

from orchestrator._channel.registry import REGISTRY_BINARY, RegistryError

V2 = Path("docker") / "registry" / "v2"


def _v2(storage: Path) -> Path:
    return storage / V2


def _blob(storage: Path, digest: str) -> Path:
    hexa = digest.split(":", 1)[-1]
    return _v2(storage) / "blobs" / "sha256" / hexa[:2] / hexa / "data"


def manifests(storage: Path, team: str | None = None) -> dict[str, set[str]]:
    """Every repository's manifest digests (``teams/<team>/…`` only, for a team)."""
    root = _v2(storage) / "repositories" / "teams"
    out: dict[str, set[str]] = {}
    if not root.is_dir():
        return out
    for revisions in root.glob("*/**/_manifests/revisions/sha256"):
        repo = str(revisions.parent.parent.parent.relative_to(root.parent))
        if team is not None and not repo.startswith(f"teams/{team}/"):
            continue
        out[repo] = {f"sha256:{d.name}" for d in revisions.iterdir() if d.is_dir()}
    return out


def _layers(storage: Path, digest: str) -> dict[str, int]:
    """The blobs a manifest names (itself, its config, its layers; an index's manifests)
    with their sizes."""
    path = _blob(storage, digest)
    try:
        doc = json.loads(path.read_bytes())
    except (OSError, ValueError):
        return {}
    found = {digest: path.stat().st_size}
    for part in [doc.get("config") or {}, *(doc.get("layers") or [])]:
        if part.get("digest"):
            found[part["digest"]] = int(part.get("size") or 0)
    for sub in doc.get("manifests") or []:
        if sub.get("digest"):
            found.update(_layers(storage, sub["digest"]))
    return found


def team_usage(storage: Path, team: str) -> int:
    """Bytes of the distinct blobs the team's manifests name."""
    blobs: dict[str, int] = {}
    for digests in manifests(storage, team).values():
        for d in digests:
            blobs.update(_layers(storage, d))
    return sum(blobs.values())


@dataclass(frozen=True)
class Collected:
    manifests: int
    freed_bytes: int


def disk_bytes(folder: Path) -> int:
    """The bytes of the files under ``folder`` (links not followed; a file that goes while
    it is walked is skipped)."""
    total = 0
    for root, _, files in os.walk(folder):
        for name in files:
            try:
                total += os.lstat(os.path.join(root, name)).st_size
            except OSError:
                continue
    return total


def collect(storage: Path, config: Path, keep: set[tuple[str, str]]) -> Collected:
    """Removes every manifest not in ``keep`` ((repository, digest) pairs) and the tags
    pointing at it, then the blobs nothing names any more. The registry must be stopped."""
    binary = shutil.which(REGISTRY_BINARY)
    if binary is None:
        raise RegistryError(f"{REGISTRY_BINARY} is not installed")
    before = disk_bytes(storage) if storage.is_dir() else 0
    removed = 0
    for repo, digests in manifests(storage).items():
        base = _v2(storage) / "repositories" / repo / "_manifests"
        for digest in digests:
            if (repo, digest) in keep:
                continue
            shutil.rmtree(base / "revisions" / "sha256" / digest.split(":", 1)[1])
            tags = base / "tags"
            for tag in (tags.iterdir() if tags.is_dir() else []):
                link = tag / "current" / "link"
                if link.is_file() and link.read_text().strip() == digest:
                    shutil.rmtree(tag)
            removed += 1
    done = subprocess.run([binary, "garbage-collect", str(config)], capture_output=True,
                          text=True, timeout=1800)
    if done.returncode != 0:
        tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise RegistryError(f"docker-registry garbage-collect failed: {tail}")
    after = disk_bytes(storage) if storage.is_dir() else 0
    return Collected(removed, max(before - after, 0))


def backup(data: Path, to: Path) -> list[Path]:
    """A consistent copy of the channel's state while it serves: both SQLite databases by
    SQLite's online backup, the keys and secrets, the challenge's registry storage (blobs
    first, then the repositories that name them, so that no copied manifest misses a
    blob). Returns what was written."""
    to.mkdir(parents=True, exist_ok=True)
    to.chmod(0o700)
    written = []
    for name in ("channel.sqlite", "results.sqlite"):
        source = data / name
        if not source.is_file():
            continue
        with sqlite3.connect(source) as src, sqlite3.connect(to / name) as dst:
            src.backup(dst)
        written.append(to / name)
    for name in ("keys", "secrets", "runner.token"):
        source = data / name
        if source.is_dir():
            shutil.copytree(source, to / name, dirs_exist_ok=True)
        elif source.is_file():
            shutil.copy2(source, to / name)
        else:
            continue
        written.append(to / name)
    storage = data / "registry" / "storage"
    if storage.is_dir():
        for part in ("blobs", "repositories"):
            src = _v2(storage) / part
            if src.is_dir():
                shutil.copytree(src, to / "registry" / "storage" / V2 / part,
                                dirs_exist_ok=True)
        written.append(to / "registry")
    return written
