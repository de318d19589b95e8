"""The results store: once-only commits, attempts, quarantine, resume, concurrent writers."""

from __future__ import annotations

import multiprocessing
import sqlite3
import time
from pathlib import Path

import pytest

from orchestrator._store import EpisodeKey, ResultsStore, StoreError
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
        assert store.counts("c1") == {"quarantined": 1, "retries": 3}
        # An organizer re-ran it (--retry-quarantined) and it completed: released.
        assert store.commit("c1", key, _result("ep3"), retry=3, node="n")
        assert store.quarantined("c1") == []
        assert store.counts("c1") == {"completed": 1, "quarantined": 0, "retries": 3}


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
