"""The results store: SQLite in WAL mode, one row per episode, committed once.

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

Counts (``tallies``) are kept in the same transaction as each write, so asking for the state
of a campaign costs the same at 10 rows as at 100,000 (``tests/benchmarks/bench_store.py``).
Every SQLite failure comes out as a ``StoreError``: ``StoreDamaged`` for a file that is not a
sound store, ``StoreWriteError`` for a write that did not happen (a full disk). Either way
what was committed before stays, and ``eagc campaign rebuild-store`` rebuilds a campaign's
rows from its episode folders (``orchestrator._campaign.rebuild``).
"""

from __future__ import annotations

import sqlite3
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from orchestrator._errors import OrchestratorError
from schemas import CampaignSpec, EpisodeResult, EpisodeStatus

SCHEMA_VERSION = 2  # 2: tallies
REBUILD = "eagc campaign rebuild-store CAMPAIGN.yaml"

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
CREATE TABLE IF NOT EXISTS tallies (
    campaign TEXT NOT NULL, name TEXT NOT NULL, n INTEGER NOT NULL,
    PRIMARY KEY (campaign, name));
"""

#: Recomputes every campaign's tallies from the rows (a store of schema 1, a rebuild).
_RETALLY = """
DELETE FROM tallies;
INSERT INTO tallies SELECT campaign, 'status:' || status, COUNT(*) FROM episodes
    GROUP BY campaign, status;
INSERT INTO tallies SELECT campaign, 'quarantined', COUNT(*) FROM quarantine GROUP BY campaign;
INSERT INTO tallies SELECT campaign, 'retries', COUNT(*) FROM attempts GROUP BY campaign;
"""


class StoreError(OrchestratorError, RuntimeError):
    """Raised when the results store cannot be used (another campaign's seeds, a newer schema,
    a damaged file, a failed write)."""


class StoreDamaged(StoreError):
    """Raised when the store file is not a sound SQLite store (truncated, overwritten,
    corrupt pages), or is empty beside episode results that it should hold."""


class StoreWriteError(StoreError):
    """Raised when a write to the store did not happen (disk full, I/O error); nothing
    committed before is lost."""


@dataclass(frozen=True, order=True)
class EpisodeKey:
    """One episode of a campaign: a submission's ``index``-th episode of ``split``."""

    submission: str
    split: str
    index: int

    def __str__(self) -> str:
        return f"{self.submission}/{self.split}/{self.index}"


@dataclass(frozen=True)
class Tallies:
    """A campaign's counts, kept as each row is written (``ResultsStore.counts``)."""

    #: Committed episodes by status (statuses with none are left out).
    by_status: Mapping[EpisodeStatus, int] = field(default_factory=dict)
    #: Episodes held back after their last retry failed.
    quarantined: int = 0
    #: Infrastructure failures recorded (each one retried or quarantined).
    retries: int = 0

    @property
    def done(self) -> int:
        """Episodes with a final result."""
        return sum(self.by_status.values())

    @property
    def completed(self) -> int:
        """Episodes that completed (the rest of ``done`` failed)."""
        return self.by_status.get(EpisodeStatus.COMPLETED, 0)


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
        #: Write failures seen by this store object (the driver exports them as a metric).
        self.errors = 0
        try:
            self.db = sqlite3.connect(self.path, isolation_level=None, timeout=30.0)
        except sqlite3.Error as e:
            raise StoreDamaged(f"cannot open the results store {self.path}: {e}") from None
        try:
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.execute("PRAGMA synchronous=FULL")
            self.db.execute("PRAGMA busy_timeout=30000")
            with self._write():
                for stmt in filter(str.strip, _DDL.split(";")):
                    self.db.execute(stmt)
                row = self.db.execute("SELECT value FROM meta WHERE key='schema'").fetchone()
                if row is None:  # a new store
                    self.db.execute("INSERT INTO meta VALUES ('schema', ?)",
                                    (str(SCHEMA_VERSION),))
                elif int(row[0]) < SCHEMA_VERSION:  # schema 1: tallies from the rows
                    for stmt in filter(str.strip, _RETALLY.split(";")):
                        self.db.execute(stmt)
                    self.db.execute("UPDATE meta SET value=? WHERE key='schema'",
                                    (str(SCHEMA_VERSION),))
            (version,) = self.db.execute("SELECT value FROM meta WHERE key='schema'").fetchone()
        except (StoreWriteError, sqlite3.Error) as e:
            self.db.close()
            if isinstance(e, StoreWriteError) and "full" in str(e):
                raise
            cause = str(e).rsplit(": ", 1)[-1]
            raise StoreDamaged(f"the results store {self.path} is damaged ({cause}); rebuild "
                               f"it from the episode folders: {REBUILD}") from None
        if int(version) > SCHEMA_VERSION:
            self.db.close()
            raise StoreError(f"{self.path} has store schema {version}; this eagc knows "
                             f"{SCHEMA_VERSION}: upgrade eagc")

    def check(self) -> None:
        """A full consistency check of the file (``PRAGMA quick_check``); StoreDamaged if it
        fails. It reads every page: the driver runs it once, at the start of a campaign."""
        try:
            rows = self.db.execute("PRAGMA quick_check").fetchall()
        except sqlite3.Error as e:
            rows = [(str(e),)]
        if rows != [("ok",)]:
            problem = "; ".join(str(r[0]) for r in rows[:3])
            raise StoreDamaged(f"the results store {self.path} is damaged ({problem}); "
                               f"rebuild it from the episode folders: {REBUILD}")

    def close(self) -> None:
        self.db.close()

    def __enter__(self) -> ResultsStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @contextmanager
    def _write(self) -> Iterator[None]:
        """One atomic transaction, taking the write lock at once. A failure of SQLite (a full
        disk, an I/O error, a damaged page) rolls back and comes out as StoreWriteError."""
        try:
            self.db.execute("BEGIN IMMEDIATE")
            try:
                yield
            except BaseException:
                if self.db.in_transaction:
                    self.db.execute("ROLLBACK")
                raise
            self.db.execute("COMMIT")
        except sqlite3.DatabaseError as e:
            self.errors += 1
            if self.db.in_transaction:
                try:
                    self.db.execute("ROLLBACK")
                except sqlite3.Error:
                    pass
            full = "full" in str(e).lower()
            raise StoreWriteError(
                f"could not write to the results store {self.path}: {e}"
                + (" (free some disk space, then run the campaign again: it resumes)"
                   if full else "")) from None

    def _tally(self, campaign: str, name: str, delta: int) -> None:
        self.db.execute(
            "INSERT INTO tallies VALUES (?, ?, ?) ON CONFLICT DO UPDATE SET n = n + excluded.n",
            (campaign, name, delta))

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
               node: str | None, at: float | None = None) -> bool:
        """Commits a final result once. False (and nothing changed) if the key has one."""
        with self._write():
            cur = self.db.execute(
                "INSERT INTO episodes VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) "
                "ON CONFLICT DO NOTHING",
                (campaign, key.submission, key.split, key.index, result.episode,
                 result.status.value, result.status.failure_kind, result.score.total, retry,
                 node, result.model_dump_json(), time.time() if at is None else at),
            )
            if cur.rowcount == 1:
                self._tally(campaign, f"status:{result.status.value}", 1)
                # An organizer's re-run of a quarantined episode succeeded.
                held = self.db.execute(
                    "DELETE FROM quarantine WHERE campaign=? AND submission=? AND split=? "
                    "AND idx=?", (campaign, key.submission, key.split, key.index))
                if held.rowcount:
                    self._tally(campaign, "quarantined", -held.rowcount)
            return cur.rowcount == 1

    def record_attempt(self, campaign: str, key: EpisodeKey, *, retry: int, episode: str,
                       message: str, node: str | None, result: EpisodeResult | None,
                       at: float | None = None) -> None:
        """Records an infrastructure failure (the episode will be retried or quarantined)."""
        with self._write():
            cur = self.db.execute(
                "INSERT INTO attempts VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?) "
                "ON CONFLICT DO NOTHING",
                (campaign, key.submission, key.split, key.index, retry, episode, message, node,
                 None if result is None else result.model_dump_json(),
                 time.time() if at is None else at),
            )
            if cur.rowcount == 1:
                self._tally(campaign, "retries", 1)

    def quarantine(self, campaign: str, key: EpisodeKey, *, episode: str, message: str,
                   retries: int) -> None:
        with self._write():
            new = self.db.execute(
                "SELECT 1 FROM quarantine WHERE campaign=? AND submission=? AND split=? "
                "AND idx=?", (campaign, key.submission, key.split, key.index)).fetchone() is None
            if new:
                self._tally(campaign, "quarantined", 1)
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

    def counts(self, campaign: str) -> Tallies:
        """Committed episodes by status, quarantined episodes and retries (kept as each
        row is written: the cost does not grow with the campaign)."""
        by_status: dict[EpisodeStatus, int] = {}
        other: dict[str, int] = {}
        for name, n in self.db.execute("SELECT name, n FROM tallies WHERE campaign=?",
                                       (campaign,)):
            status = name.removeprefix("status:")
            if status != name:
                if n:
                    by_status[EpisodeStatus(status)] = int(n)
            else:
                other[name] = int(n)
        return Tallies(by_status, quarantined=other.pop("quarantined", 0),
                       retries=other.pop("retries", 0))

    def retally(self) -> None:
        """Recomputes every count from the rows (after a rebuild or a repair by hand)."""
        with self._write():
            for stmt in filter(str.strip, _RETALLY.split(";")):
                self.db.execute(stmt)

    def episode_ids(self, campaign: str) -> set[str]:
        return {r[0] for r in self.db.execute("SELECT episode FROM episodes WHERE campaign=?",
                                               (campaign,))}

    def holds_results(self, campaign: str) -> bool:
        return self.db.execute("SELECT 1 FROM episodes WHERE campaign=? LIMIT 1",
                               (campaign,)).fetchone() is not None

    def attempt_log(self, campaign: str) -> list[dict[str, object]]:
        cols = ("submission", "split", "index", "retry", "episode", "message", "node", "at")
        return [dict(zip(cols, row, strict=True)) for row in self.db.execute(
            "SELECT submission, split, idx, retry, episode, message, node, at FROM attempts "
            "WHERE campaign=? ORDER BY at", (campaign,))]
