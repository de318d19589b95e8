"""The results store: SQLite in WAL mode, one row per episode, committed once (DESIGN §7).

Tables (one store can hold several campaigns; every key starts with the campaign)::

    campaigns   name → track, phase, spec, seed commitment, planned episode count
    episodes    (campaign, submission, split, idx) → final result   PRIMARY KEY: at most once
    attempts    (campaign, submission, split, idx, retry) → an infrastructure failure, retried
    quarantine  (campaign, submission, split, idx) → held back after the last retry failed

An episode's final result is written with ``INSERT … ON CONFLICT DO NOTHING``: a second
commit of the same key (a driver restarted after a crash, a task that came back twice)
changes nothing and reports that it was a duplicate. ``synchronous=FULL``: a commit that
returned survives a crash of the process or the machine. A restarted campaign asks the
store what is missing and runs only that. Seeds are never stored here (only the
commitment), so the store may be shared with the teams' failure reports being derived from it.
"""

from __future__ import annotations

import sqlite3
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from orchestrator._errors import OrchestratorError
from schemas import CampaignSpec, EpisodeResult

SCHEMA_VERSION = 1

_DDL = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS campaigns (
    name TEXT PRIMARY KEY, track TEXT NOT NULL, phase TEXT NOT NULL, spec TEXT NOT NULL,
    commitment TEXT NOT NULL, planned INTEGER NOT NULL, created_at REAL NOT NULL);
CREATE TABLE IF NOT EXISTS episodes (
    campaign TEXT NOT NULL, submission TEXT NOT NULL, split TEXT NOT NULL, idx INTEGER NOT NULL,
    episode TEXT NOT NULL UNIQUE, status TEXT NOT NULL, kind TEXT, score REAL NOT NULL,
    retry INTEGER NOT NULL, node TEXT, result TEXT NOT NULL, committed_at REAL NOT NULL,
    PRIMARY KEY (campaign, submission, split, idx));
CREATE TABLE IF NOT EXISTS attempts (
    campaign TEXT NOT NULL, submission TEXT NOT NULL, split TEXT NOT NULL, idx INTEGER NOT NULL,
    retry INTEGER NOT NULL, episode TEXT NOT NULL, message TEXT NOT NULL, node TEXT,
    result TEXT, at REAL NOT NULL,
    PRIMARY KEY (campaign, submission, split, idx, retry));
CREATE TABLE IF NOT EXISTS quarantine (
    campaign TEXT NOT NULL, submission TEXT NOT NULL, split TEXT NOT NULL, idx INTEGER NOT NULL,
    episode TEXT NOT NULL, message TEXT NOT NULL, retries INTEGER NOT NULL, at REAL NOT NULL,
    PRIMARY KEY (campaign, submission, split, idx));
"""


class StoreError(OrchestratorError, RuntimeError):
    """Raised when the store does not match the campaign (changed seeds, newer schema)."""


@dataclass(frozen=True, order=True)
class EpisodeKey:
    """One episode of a campaign: a submission's ``index``-th episode of ``split``."""

    submission: str
    split: str
    index: int

    def __str__(self) -> str:
        return f"{self.submission}/{self.split}/{self.index}"


@dataclass(frozen=True)
class StoredEpisode:
    key: EpisodeKey
    result: EpisodeResult
    retry: int
    node: str | None
    committed_at: float


@dataclass(frozen=True)
class Quarantined:
    key: EpisodeKey
    episode: str
    message: str
    retries: int


class ResultsStore:
    """One SQLite file; safe to open from several processes (WAL, busy timeout)."""

    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.db = sqlite3.connect(self.path, isolation_level=None, timeout=30.0)
        self.db.execute("PRAGMA journal_mode=WAL")
        self.db.execute("PRAGMA synchronous=FULL")
        self.db.execute("PRAGMA busy_timeout=30000")
        with self._write():
            for stmt in filter(str.strip, _DDL.split(";")):
                self.db.execute(stmt)
            self.db.execute("INSERT OR IGNORE INTO meta VALUES ('schema', ?)",
                            (str(SCHEMA_VERSION),))
        (version,) = self.db.execute("SELECT value FROM meta WHERE key='schema'").fetchone()
        if int(version) > SCHEMA_VERSION:
            raise StoreError(f"{self.path} has store schema {version}; this eagc knows "
                             f"{SCHEMA_VERSION}: upgrade eagc")

    def close(self) -> None:
        self.db.close()

    def __enter__(self) -> ResultsStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @contextmanager
    def _write(self) -> Iterator[None]:
        """One atomic transaction, taking the write lock at once."""
        self.db.execute("BEGIN IMMEDIATE")
        try:
            yield
        except BaseException:
            self.db.execute("ROLLBACK")
            raise
        self.db.execute("COMMIT")

    # ------------------------------------------------------------------ campaigns
    def register(self, spec: CampaignSpec, commitment: str, planned: int) -> None:
        """Records the campaign; refuses a store that committed to other seeds."""
        with self._write():
            row = self.db.execute("SELECT commitment, track FROM campaigns WHERE name=?",
                                  (spec.name,)).fetchone()
            if row is None:
                self.db.execute(
                    "INSERT INTO campaigns VALUES (?, ?, ?, ?, ?, ?, ?)",
                    (spec.name, spec.track, spec.phase, spec.model_dump_json(), commitment,
                     planned, time.time()),
                )
                return
            if row[0] != commitment or row[1] != spec.track:
                raise StoreError(
                    f"{self.path} already holds campaign {spec.name!r} with another track or "
                    "seed list (the secret, the splits or the episode counts changed). Its "
                    "results cannot be mixed with these: give the campaign a new name or a "
                    "new output folder."
                )
            self.db.execute("UPDATE campaigns SET spec=?, planned=? WHERE name=?",
                            (spec.model_dump_json(), planned, spec.name))

    def commitment(self, campaign: str) -> str | None:
        row = self.db.execute("SELECT commitment FROM campaigns WHERE name=?",
                              (campaign,)).fetchone()
        return None if row is None else str(row[0])

    def campaigns(self) -> list[str]:
        return [r[0] for r in self.db.execute("SELECT name FROM campaigns ORDER BY name")]

    # ------------------------------------------------------------------ episodes
    def commit(self, campaign: str, key: EpisodeKey, result: EpisodeResult, *, retry: int,
               node: str | None) -> bool:
        """Commits a final result once. False (and nothing changed) if the key has one."""
        with self._write():
            cur = self.db.execute(
                "INSERT INTO episodes VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) "
                "ON CONFLICT DO NOTHING",
                (campaign, key.submission, key.split, key.index, result.episode,
                 result.status.value, result.status.failure_kind, result.score.total, retry,
                 node, result.model_dump_json(), time.time()),
            )
            if cur.rowcount == 1:  # an organizer's re-run of a quarantined episode succeeded
                self.db.execute(
                    "DELETE FROM quarantine WHERE campaign=? AND submission=? AND split=? "
                    "AND idx=?", (campaign, key.submission, key.split, key.index))
            return cur.rowcount == 1

    def record_attempt(self, campaign: str, key: EpisodeKey, *, retry: int, episode: str,
                       message: str, node: str | None, result: EpisodeResult | None) -> None:
        """Records an infrastructure failure (the episode will be retried or quarantined)."""
        with self._write():
            self.db.execute(
                "INSERT INTO attempts VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?) "
                "ON CONFLICT DO NOTHING",
                (campaign, key.submission, key.split, key.index, retry, episode, message, node,
                 None if result is None else result.model_dump_json(), time.time()),
            )

    def quarantine(self, campaign: str, key: EpisodeKey, *, episode: str, message: str,
                   retries: int) -> None:
        with self._write():
            self.db.execute(
                "INSERT INTO quarantine VALUES (?, ?, ?, ?, ?, ?, ?, ?) ON CONFLICT DO UPDATE "
                "SET episode=excluded.episode, message=excluded.message, "
                "retries=excluded.retries, at=excluded.at",
                (campaign, key.submission, key.split, key.index, episode, message, retries,
                 time.time()),
            )

    def attempts(self, campaign: str, key: EpisodeKey) -> int:
        """Infrastructure failures recorded for ``key`` (the next retry's number)."""
        (n,) = self.db.execute(
            "SELECT COUNT(*) FROM attempts WHERE campaign=? AND submission=? AND split=? "
            "AND idx=?", (campaign, key.submission, key.split, key.index)).fetchone()
        return int(n)

    def done(self, campaign: str) -> set[EpisodeKey]:
        return {EpisodeKey(s, sp, i) for s, sp, i in self.db.execute(
            "SELECT submission, split, idx FROM episodes WHERE campaign=?", (campaign,))}

    def quarantined(self, campaign: str) -> list[Quarantined]:
        return [Quarantined(EpisodeKey(s, sp, i), ep, msg, n) for s, sp, i, ep, msg, n in
                self.db.execute(
                    "SELECT submission, split, idx, episode, message, retries FROM quarantine "
                    "WHERE campaign=? ORDER BY submission, split, idx", (campaign,))]

    def results(self, campaign: str) -> list[StoredEpisode]:
        rows = self.db.execute(
            "SELECT submission, split, idx, result, retry, node, committed_at FROM episodes "
            "WHERE campaign=? ORDER BY submission, split, idx", (campaign,))
        return [StoredEpisode(EpisodeKey(s, sp, i), EpisodeResult.model_validate_json(r), n,
                              node, t) for s, sp, i, r, n, node, t in rows]

    def counts(self, campaign: str) -> dict[str, int]:
        """Committed episodes by status, plus ``quarantined`` and ``retries``."""
        out = {status: int(n) for status, n in self.db.execute(
            "SELECT status, COUNT(*) FROM episodes WHERE campaign=? GROUP BY status",
            (campaign,))}
        (out["quarantined"],) = self.db.execute(
            "SELECT COUNT(*) FROM quarantine WHERE campaign=?", (campaign,)).fetchone()
        (out["retries"],) = self.db.execute(
            "SELECT COUNT(*) FROM attempts WHERE campaign=?", (campaign,)).fetchone()
        return out

    def attempt_log(self, campaign: str) -> list[dict[str, object]]:
        cols = ("submission", "split", "index", "retry", "episode", "message", "node", "at")
        return [dict(zip(cols, row, strict=True)) for row in self.db.execute(
            "SELECT submission, split, idx, retry, episode, message, node, at FROM attempts "
            "WHERE campaign=? ORDER BY at", (campaign,))]
