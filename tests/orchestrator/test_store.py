"""The results store: once-only commits, attempts, quarantine, resume, concurrent writers."""

from __future__ import annotations

import multiprocessing
import sqlite3
import time
from pathlib import Path

import pytest

from orchestrator._results.store import (
    EpisodeKey,
    ResultsStore,
    StoreDamaged,
    StoreError,
    StoreWriteError,
    Tallies,
)
from schemas import CampaignSpec, EpisodeResult, EpisodeStats, EpisodeStatus, ScoreCard

SPEC = CampaignSpec.model_validate({
    "name": "c1", "track": "sanity",
    "splits": [{"name": "standard", "episodes": 2}],
    "submissions": [{"team": "a", "image": "x"}, {"team": "b", "image": "y"}],
})


def _result(episode: str, status: EpisodeStatus = EpisodeStatus.COMPLETED,
            total: float = 0.5) -> EpisodeResult:
    now = time.time()
    return EpisodeResult(
        episode=episode, track="sanity", split="standard", image="x", runtime="docker",
        status=status, score=ScoreCard(track="sanity", total=total, components={}, weights={}),
        stats=EpisodeStats(), started_at=now, finished_at=now)


def test_commit_is_once_only(tmp_path: Path) -> None:
    with ResultsStore(tmp_path / "r.sqlite") as store:
        store.register(SPEC, "c0ffee", 4)
        key = EpisodeKey("a", "standard", 0)
        assert store.commit("c1", key, _result("ep1"), retry=0, node="n1")
        assert not store.commit("c1", key, _result("ep2", total=0.9), retry=1, node="n2")
        (got,) = store.results("c1")
        assert got.result.episode == "ep1" and got.node == "n1" and got.retry == 0
        assert store.done("c1") == {key}
        mode = store.db.execute("PRAGMA journal_mode").fetchone()[0]
        assert mode == "wal"


def test_attempts_quarantine_and_release(tmp_path: Path) -> None:
    with ResultsStore(tmp_path / "r.sqlite") as store:
        store.register(SPEC, "c0ffee", 4)
        key = EpisodeKey("b", "standard", 1)
        for retry in range(3):
            store.record_attempt("c1", key, retry=retry, episode=f"ep{retry}",
                                 message="sim host crashed", node="n", result=None)
        store.record_attempt("c1", key, retry=2, episode="dup", message="x", node=None,
                             result=None)  # the same attempt twice is recorded once
        assert store.attempts("c1", key) == 3
        store.quarantine("c1", key, episode="ep2", message="sim host crashed", retries=2)
        assert [q.key for q in store.quarantined("c1")] == [key]
        assert store.counts("c1") == Tallies({}, quarantined=1, retries=3)
        # An organizer re-ran it (--retry-quarantined) and it completed: released.
        assert store.commit("c1", key, _result("ep3"), retry=3, node="n")
        assert store.quarantined("c1") == []
        assert store.counts("c1") == Tallies({EpisodeStatus.COMPLETED: 1}, retries=3)


def test_store_refuses_other_seeds(tmp_path: Path) -> None:
    with ResultsStore(tmp_path / "r.sqlite") as store:
        store.register(SPEC, "c0ffee", 4)
        store.register(SPEC, "c0ffee", 4)  # a resumed campaign: fine
        with pytest.raises(StoreError, match="seed list"):
            store.register(SPEC, "deadbeef", 4)


def _writer(path: str, worker: int, barrier: object) -> None:
    store = ResultsStore(path)
    barrier.wait()  # type: ignore[attr-defined]
    for i in range(20):
        store.commit("c1", EpisodeKey("a", "standard", i), _result(f"ep{worker}-{i}"),
                     retry=0, node=str(worker))
    store.close()


def test_concurrent_drivers_commit_each_key_once(tmp_path: Path) -> None:
    path = str(tmp_path / "r.sqlite")
    ResultsStore(path).close()
    ctx = multiprocessing.get_context("spawn")
    barrier = ctx.Barrier(3)
    procs = [ctx.Process(target=_writer, args=(path, w, barrier)) for w in range(3)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(60)
        assert p.exitcode == 0
    rows = sqlite3.connect(path).execute(
        "SELECT idx, COUNT(*) FROM episodes GROUP BY idx").fetchall()
    assert len(rows) == 20 and all(n == 1 for _, n in rows)


# ---------------------------------------------------------------------------- issue 13
def _fill(store: ResultsStore, n: int, campaign: str = "c1") -> None:
    store.register(SPEC.model_copy(update={"name": campaign}), "c0ffee", n)
    for i in range(n):
        status = EpisodeStatus.COMPLETED if i % 3 else EpisodeStatus.AGENT_CRASH
        store.commit(campaign, EpisodeKey("a", "standard", i), _result(f"{campaign}-{i}",
                                                                       status), retry=0,
                     node="n")


def _recount(path: Path, campaign: str) -> Tallies:
    db = sqlite3.connect(path)
    by_status = {EpisodeStatus(status): n for status, n in db.execute(
        "SELECT status, COUNT(*) FROM episodes WHERE campaign=? GROUP BY status",
        (campaign,)).fetchall()}
    (quarantined,), = db.execute("SELECT COUNT(*) FROM quarantine WHERE campaign=?",
                                 (campaign,)).fetchall()
    (retries,), = db.execute("SELECT COUNT(*) FROM attempts WHERE campaign=?",
                             (campaign,)).fetchall()
    return Tallies(by_status, quarantined=quarantined, retries=retries)


def test_counts_are_kept_incrementally(tmp_path: Path) -> None:
    """counts() reads the tallies only: no statement of it touches the episode rows, so
    its cost does not grow with the campaign (issue 13 §7), and it agrees with a recount."""
    path = tmp_path / "r.sqlite"
    with ResultsStore(path) as store:
        _fill(store, 30)
        _fill(store, 5, campaign="other")
        key = EpisodeKey("b", "standard", 0)
        store.record_attempt("c1", key, retry=0, episode="x0", message="m", node=None,
                             result=None)
        store.quarantine("c1", key, episode="x0", message="m", retries=0)
        store.quarantine("c1", key, episode="x0", message="m again", retries=0)  # once
        statements: list[str] = []
        store.db.set_trace_callback(statements.append)
        counts = store.counts("c1")
        store.db.set_trace_callback(None)
        assert statements and all("episodes" not in s for s in statements), statements
        assert counts == _recount(path, "c1") == Tallies(
            {EpisodeStatus.COMPLETED: 20, EpisodeStatus.AGENT_CRASH: 10},
            quarantined=1, retries=1)
        assert (counts.done, counts.completed) == (30, 20)
        assert store.commit("c1", key, _result("x1"), retry=1, node=None)  # released
        assert store.counts("c1") == _recount(path, "c1")
        assert store.counts("other") == _recount(path, "other")


def test_a_schema_1_store_gets_its_tallies(tmp_path: Path) -> None:
    path = tmp_path / "r.sqlite"
    with ResultsStore(path) as store:
        _fill(store, 7)
        store.db.execute("DROP TABLE tallies")
        store.db.execute("UPDATE meta SET value='1' WHERE key='schema'")
    with ResultsStore(path) as store:  # an older eagc's store, opened by this one
        assert store.counts("c1") == _recount(path, "c1")


def _damage(path: Path, how: str) -> None:
    data = path.read_bytes()
    if how == "truncated":
        path.write_bytes(data[: len(data) // 3])
    elif how == "overwritten":
        path.write_bytes(b"this is not a database at all\n" * 200)
    elif how == "corrupt pages":  # the header stays, every page after the first is noise
        path.write_bytes(data[:4096] + bytes(range(256)) * ((len(data) - 4096) // 256))


@pytest.mark.parametrize("how", ["truncated", "overwritten", "corrupt pages"])
def test_a_damaged_store_is_refused_with_the_rebuild_command(tmp_path: Path, how: str) -> None:
    path = tmp_path / "r.sqlite"
    with ResultsStore(path) as store:
        _fill(store, 200)
        store.db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    _damage(path, how)
    with pytest.raises(StoreDamaged, match="eagc campaign rebuild-store"):
        store = ResultsStore(path)
        try:
            store.check()
        finally:
            store.close()


def test_a_full_store_fails_as_a_store_error_and_keeps_its_rows(tmp_path: Path) -> None:
    """SQLite's own 'database or disk is full' (the page limit standing in for a full disk:
    the error and the code path are the same) comes out as StoreWriteError, rolled back."""
    path = tmp_path / "r.sqlite"
    with ResultsStore(path) as store:
        _fill(store, 3)
        (pages,) = store.db.execute("PRAGMA page_count").fetchone()
        store.db.execute(f"PRAGMA max_page_count={pages}")
        big = _result("big").model_copy(update={"image": "x" * 200_000})
        with pytest.raises(StoreWriteError, match="full"):
            store.commit("c1", EpisodeKey("a", "standard", 99), big, retry=0, node=None)
        assert store.errors == 1
        assert len(store.results("c1")) == 3 and store.counts("c1") == _recount(path, "c1")
        store.commit("c1", EpisodeKey("a", "standard", 4), _result("small"), retry=0,
                     node=None)  # the store still works once there is room
