"""The channel's database: teams, their tokens, submissions and each one's history.

SQLite in WAL mode, ``synchronous=FULL``: an answer the API gave survives a crash. Every
change of a submission's state is one transaction that also appends to its history, so a
submission is always in exactly one state and its history says how it got there. Times come
from the channel's clock (``Clock``), which tests and rehearsals compress.

Tokens are random (256 bits) and stored only as their SHA-256: shown once, never again.
"""

from __future__ import annotations

import hashlib
import json
import secrets
import sqlite3
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from orchestrator._errors import OrchestratorError
from schemas import HistoryEntry, SubmissionState

S = SubmissionState

_DDL = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS teams (
    name TEXT PRIMARY KEY, created_at REAL NOT NULL, disabled INTEGER NOT NULL DEFAULT 0);
CREATE TABLE IF NOT EXISTS tokens (
    hash TEXT PRIMARY KEY, team TEXT NOT NULL, created_at REAL NOT NULL,
    expires_at REAL NOT NULL, revoked_at REAL);
CREATE TABLE IF NOT EXISTS submissions (
    id TEXT PRIMARY KEY, team TEXT NOT NULL, phase TEXT NOT NULL,
    repository TEXT NOT NULL, digest TEXT NOT NULL, image_id TEXT,
    note TEXT NOT NULL, disclosure TEXT, state TEXT NOT NULL, reason TEXT NOT NULL,
    created_at REAL NOT NULL, updated_at REAL NOT NULL, queued_at REAL,
    lease_owner TEXT, lease_until REAL, infra_retries INTEGER NOT NULL DEFAULT 0,
    lease_expiries INTEGER NOT NULL DEFAULT 0,
    episodes_done INTEGER NOT NULL DEFAULT 0, episodes_planned INTEGER NOT NULL DEFAULT 0,
    preflight TEXT NOT NULL DEFAULT '', wall_s REAL, result TEXT,
    charged INTEGER NOT NULL DEFAULT 1, day TEXT NOT NULL, rerun_of TEXT);
CREATE INDEX IF NOT EXISTS submissions_state ON submissions (state, queued_at);
CREATE INDEX IF NOT EXISTS submissions_quota ON submissions (team, phase, day);
CREATE TABLE IF NOT EXISTS history (
    submission TEXT NOT NULL, at REAL NOT NULL, state TEXT NOT NULL, detail TEXT NOT NULL);
CREATE INDEX IF NOT EXISTS history_submission ON history (submission, at);
CREATE TABLE IF NOT EXISTS grants (
    team TEXT NOT NULL, phase TEXT NOT NULL, day TEXT NOT NULL, n INTEGER NOT NULL);
CREATE TABLE IF NOT EXISTS refusals (
    at REAL NOT NULL, client TEXT NOT NULL, method TEXT NOT NULL, path TEXT NOT NULL,
    status INTEGER NOT NULL, detail TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS actions (
    at REAL NOT NULL, who TEXT NOT NULL, action TEXT NOT NULL, target TEXT NOT NULL,
    why TEXT NOT NULL);
"""


#: Identical refusals (client, method, path, status) closer than this are counted, not kept.
REFUSAL_REPEAT_S = 10.0


class ChannelError(OrchestratorError):
    """Raised when the channel cannot do what was asked; the message says why and what
    to do. ``status`` is the HTTP status the API answers with."""

    def __init__(self, message: str, status: int = 400) -> None:
        super().__init__(message)
        self.status = status


class Clock:
    """The channel's time: the wall clock, or a compressed one (``speed`` channel seconds
    per real second from ``origin`` at the wall time ``real0``) for tests and rehearsals.
    A compressed clock is kept in the channel's database (``state``), so that every
    process working on its data reads the same time."""

    def __init__(self, origin: float | None = None, speed: float = 1.0,
                 real0: float | None = None) -> None:
        self.origin = time.time() if origin is None else origin
        self.speed = speed
        compressed = origin is not None or speed != 1.0
        self._real0 = (time.time() if real0 is None else real0) if compressed else None

    def now(self) -> float:
        if self._real0 is None:
            return time.time()
        return self.origin + (time.time() - self._real0) * self.speed

    def utc(self, t: float | None = None) -> datetime:
        return datetime.fromtimestamp(self.now() if t is None else t, UTC)

    def real_s(self, channel_s: float) -> float:
        """How many real seconds ``channel_s`` of the channel's time last (a lease's)."""
        return channel_s / self.speed if self.speed > 0 else channel_s

    def state(self) -> str | None:
        """The clock as JSON for other processes (None: the wall clock)."""
        if self._real0 is None:
            return None
        return json.dumps({"origin": self.origin, "speed": self.speed, "real0": self._real0})

    @classmethod
    def of(cls, state: str | None) -> Clock:
        return cls() if not state else cls(**json.loads(state))


def token_hash(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


@dataclass(frozen=True)
class TokenCheck:
    """Who a token belongs to, or why it is refused (``problem`` set, ``team`` None)."""

    team: str | None
    problem: str = ""


@dataclass(frozen=True)
class Row:
    """A submission's row (the database's columns, typed)."""

    id: str
    team: str
    phase: str
    repository: str
    digest: str
    image_id: str | None
    note: str
    disclosure: str | None
    state: SubmissionState
    reason: str
    created_at: float
    updated_at: float
    queued_at: float | None
    lease_owner: str | None
    lease_until: float | None
    infra_retries: int
    lease_expiries: int
    episodes_done: int
    episodes_planned: int
    preflight: str
    wall_s: float | None
    result: dict[str, Any] | None
    charged: bool
    day: str
    rerun_of: str | None


class ChannelDB:
    """One channel's data (``<data>/channel.sqlite``), shared by the API's threads."""

    def __init__(self, path: Path, clock: Clock | None = None) -> None:
        self.path = path
        self.clock = clock or Clock()
        path.parent.mkdir(parents=True, exist_ok=True)
        self.db = sqlite3.connect(path, check_same_thread=False, isolation_level=None,
                                  timeout=30)
        self.db.execute("PRAGMA journal_mode=WAL")
        self.db.execute("PRAGMA synchronous=FULL")
        self.db.executescript(_DDL)
        self._lock = threading.RLock()
        self._refused: dict[tuple[str, str, str, int], tuple[float, int]] = {}

    def close(self) -> None:
        self.db.close()

    @contextmanager
    def tx(self) -> Iterator[sqlite3.Connection]:
        """One write transaction (serialized between the API's threads and processes)."""
        with self._lock:
            self.db.execute("BEGIN IMMEDIATE")
            try:
                yield self.db
            except BaseException:
                self.db.execute("ROLLBACK")
                raise
            self.db.execute("COMMIT")

    # ------------------------------------------------------------------ meta
    def meta(self, key: str) -> str | None:
        row = self.db.execute("SELECT value FROM meta WHERE key=?", (key,)).fetchone()
        return None if row is None else str(row[0])

    def set_meta(self, key: str, value: str, *, keep: bool = False) -> str:
        """Sets ``key`` (``keep``: only where unset); returns the value it holds."""
        with self.tx() as db:
            verb = "INSERT OR IGNORE" if keep else "INSERT OR REPLACE"
            db.execute(f"{verb} INTO meta VALUES (?, ?)", (key, value))
        return self.meta(key) or value

    # ------------------------------------------------------------------ teams
    def add_team(self, name: str) -> bool:
        """Adds a team; False when it exists already."""
        with self.tx() as db:
            cur = db.execute("INSERT OR IGNORE INTO teams VALUES (?, ?, 0)",
                             (name, self.clock.now()))
            return cur.rowcount == 1

    def teams(self) -> list[tuple[str, float, bool]]:
        return [(r[0], r[1], bool(r[2])) for r in
                self.db.execute("SELECT name, created_at, disabled FROM teams ORDER BY name")]

    def has_team(self, name: str) -> bool:
        return self.db.execute("SELECT 1 FROM teams WHERE name=?", (name,)).fetchone() is not None

    def new_token(self, team: str, days: float) -> tuple[str, float]:
        """A fresh token for ``team`` (its earlier ones revoked); returns it and its expiry."""
        if not self.has_team(team):
            raise ChannelError(f"no team {team!r}: add it first (eagc challenge teams add "
                               f"{team})", 404)
        token = f"eagc_{secrets.token_urlsafe(32)}"
        now = self.clock.now()
        expires = now + days * 86400
        with self.tx() as db:
            db.execute("UPDATE tokens SET revoked_at=? WHERE team=? AND revoked_at IS NULL",
                       (now, team))
            db.execute("INSERT INTO tokens VALUES (?, ?, ?, ?, NULL)",
                       (token_hash(token), team, now, expires))
        return token, expires

    def check_token(self, token: str) -> TokenCheck:
        row = self.db.execute("SELECT team, expires_at, revoked_at FROM tokens WHERE hash=?",
                              (token_hash(token),)).fetchone()
        if row is None:
            return TokenCheck(None, "this token is not one the channel issued (a typo, or "
                              "another challenge's): check `eagc login`'s --token")
        team, expires, revoked = row
        when = self.clock.utc
        if revoked is not None:
            return TokenCheck(None, f"this token was revoked on "
                              f"{when(revoked):%Y-%m-%d %H:%M} UTC when a new one was made for "
                              f"team {team}: log in with the newest one (ask the organizers)")
        if expires <= self.clock.now():
            return TokenCheck(None, f"this token expired on {when(expires):%Y-%m-%d %H:%M} "
                              f"UTC: ask the organizers for a new one")
        disabled = self.db.execute("SELECT disabled FROM teams WHERE name=?",
                                   (team,)).fetchone()
        if disabled and disabled[0]:
            return TokenCheck(None, f"team {team} is disabled: ask the organizers why")
        return TokenCheck(str(team))

    # ------------------------------------------------------------------ submissions
    def create(self, *, team: str, phase: str, repository: str, digest: str, note: str,
               disclosure: str | None, planned: int,
               check: Any = None, charged: bool = True, rerun_of: str | None = None,
               state: SubmissionState = S.RECEIVED) -> str:
        """A new submission; ``check(db)`` runs first in the same transaction (the quota:
        two submits at once cannot both take the last one)."""
        now = self.clock.now()
        sid = f"s-{secrets.token_hex(5)}"
        with self.tx() as db:
            if check is not None:
                check(db)
            db.execute(
                "INSERT INTO submissions (id, team, phase, repository, digest, note, "
                "disclosure, state, reason, created_at, updated_at, episodes_planned, "
                "charged, day, rerun_of, queued_at) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (sid, team, phase, repository, digest, note, disclosure, str(state),
                 "waiting for its pre-flight" if state == S.RECEIVED else "waiting for a "
                 "runner", now, now, planned, int(charged), self.day(now), rerun_of,
                 now if state == S.QUEUED else None))
            self._history(db, sid, state, f"{repository}@{digest}")
        return sid

    def day(self, t: float | None = None) -> str:
        """The UTC day of ``t`` (now), as quotas count it."""
        return self.clock.utc(t).strftime("%Y-%m-%d")

    def record_action(self, db: sqlite3.Connection, who: str, action: str, target: str,
                      why: str) -> None:
        """An organizer's action: who, when, what, on what, why (``eagc challenge``)."""
        db.execute("INSERT INTO actions VALUES (?, ?, ?, ?, ?)",
                   (self.clock.now(), who, action, target, why))

    def record_refusal(self, client: str, method: str, path: str, status: int,
                       detail: str) -> None:
        """A request the API refused (who asked what, and why): hostile or mistaken, it is
        kept (``eagc challenge log``). The same refusal to the same client within
        ``REFUSAL_REPEAT_S`` is counted, not written again: a client that retries on 429
        in a loop writes a row every few seconds, saying how many it stood for."""
        key = (client, method, path, status)
        now = time.monotonic()
        with self._lock:
            last, skipped = self._refused.get(key, (-1e9, 0))
            if now - last < REFUSAL_REPEAT_S:
                self._refused[key] = (last, skipped + 1)
                return
            self._refused[key] = (now, 0)
            if len(self._refused) > 10_000:
                self._refused.clear()
        if skipped:
            detail = f"{detail} (and {skipped} more like it before)"
        try:
            with self.tx() as db:
                db.execute("INSERT INTO refusals VALUES (?, ?, ?, ?, ?, ?)",
                           (self.clock.now(), client[:100], method[:10], path[:300], status,
                            detail[:500]))
        except sqlite3.Error:  # never fail a refusal for its record
            pass

    def refusals(self, limit: int = 100) -> list[tuple[float, str, str, str, int, str]]:
        return list(self.db.execute(
            "SELECT * FROM (SELECT * FROM refusals ORDER BY at DESC, rowid DESC LIMIT ?) "
            "ORDER BY at", (limit,)))

    def actions(self) -> list[tuple[float, str, str, str, str]]:
        return list(self.db.execute("SELECT * FROM actions ORDER BY at, rowid"))

    def _history(self, db: sqlite3.Connection, sid: str, state: SubmissionState,
                 detail: str) -> None:
        db.execute("INSERT INTO history VALUES (?, ?, ?, ?)",
                   (sid, self.clock.now(), str(state), detail))

    def move(self, db: sqlite3.Connection, sid: str, state: SubmissionState, reason: str,
             detail: str | None = None, **columns: Any) -> None:
        """Sets a submission's state (and ``columns``) and records it in its history."""
        sets = ", ".join(f"{k}=?" for k in columns)
        db.execute(f"UPDATE submissions SET state=?, reason=?, updated_at=?"
                   f"{', ' + sets if sets else ''} WHERE id=?",
                   (str(state), reason, self.clock.now(), *columns.values(), sid))
        self._history(db, sid, state, reason if detail is None else detail)

    def get(self, sid: str) -> Row | None:
        row = self.db.execute("SELECT * FROM submissions WHERE id=?", (sid,)).fetchone()
        return None if row is None else _row(row)

    def rows(self, *, team: str | None = None, phase: str | None = None,
             states: tuple[SubmissionState, ...] = ()) -> list[Row]:
        where, args = [], []
        if team is not None:
            where.append("team=?")
            args.append(team)
        if phase is not None:
            where.append("phase=?")
            args.append(phase)
        if states:
            where.append(f"state IN ({', '.join('?' * len(states))})")
            args += [str(s) for s in states]
        sql = "SELECT * FROM submissions" + (f" WHERE {' AND '.join(where)}" if where else "")
        return [_row(r) for r in self.db.execute(sql + " ORDER BY created_at, id", args)]

    def history(self, sid: str) -> list[HistoryEntry]:
        return [HistoryEntry(at=self.clock.utc(at), state=SubmissionState(state), detail=d)
                for at, state, d in self.db.execute(
                    "SELECT at, state, detail FROM history WHERE submission=? "
                    "ORDER BY at, rowid", (sid,))]

    def queue(self) -> list[Row]:
        """Queued submissions, first to run first."""
        return [_row(r) for r in self.db.execute(
            "SELECT * FROM submissions WHERE state=? ORDER BY queued_at, id", (str(S.QUEUED),))]

    def seconds_per_episode(self) -> float | None:
        """The measured run time per episode of the scored runs (None before the first)."""
        row = self.db.execute("SELECT SUM(wall_s), SUM(episodes_planned) FROM submissions "
                              "WHERE state=? AND wall_s IS NOT NULL", (str(S.SCORED),)
                              ).fetchone()
        return None if not row or not row[1] else float(row[0]) / float(row[1])


def _row(r: tuple[Any, ...]) -> Row:
    values = list(r)
    values[8] = SubmissionState(values[8])
    values[21] = json.loads(values[21]) if values[21] else None
    values[22] = bool(values[22])
    return Row(*values)
