"""Results store benchmark: commits per second as the campaign grows (issue 13 §7).

What the driver does per finished episode is one ``ResultsStore.commit`` (a durable
transaction: WAL, ``synchronous=FULL``) followed by ``counts`` (the campaign's state for the
metrics). Both are timed together at campaigns of 1,000, 10,000 and 100,000 committed rows,
beside the peer measured in the same run, interleaved in rounds so that both see the same
disk: a bare SQLite insert of the same row into a table with the same key, journal mode and
synchronous setting, one transaction per insert (what a store with no counting and no
bookkeeping at all would cost). Both are bound by the disk's fsync: the ratio is ours. The
last column is the store as it was before its counts were kept (each commit followed by a
recount of the campaign's rows), measured the same way.

The rows are real ``EpisodeResult`` JSON (about 1.5 kB). Filling a store to 100,000 rows
is done with one bulk transaction (not timed); then ``--commits`` commits are timed at each
size. The store lives in a temp dir on the same disk as /tmp.

Run:  python tests/benchmarks/bench_store.py [--commits 500] [--sizes 1000,10000,100000]
Goal: at least 1,000 commits/s at 100,000 rows.
"""

from __future__ import annotations

import argparse
import sqlite3
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import load_average, machine_line  # noqa: E402

from orchestrator._results.store import EpisodeKey, ResultsStore  # noqa: E402
from schemas import (  # noqa: E402
    CampaignSpec,
    EpisodeResult,
    EpisodeStats,
    EpisodeStatus,
    ScoreCard,
)

SPEC = CampaignSpec.model_validate({
    "name": "bench", "track": "sanity",
    "splits": [{"name": "standard", "episodes": 1}],
    "submissions": [{"team": "t0", "image": "x"}],
})


def _result(i: int) -> EpisodeResult:
    now = time.time()
    status = EpisodeStatus.COMPLETED if i % 4 else EpisodeStatus.AGENT_TIMEOUT
    return EpisodeResult(
        episode=f"ep{i:016x}", track="sanity", split="standard", image="sha256:" + "a" * 64,
        runtime="docker", status=status,
        score=ScoreCard(track="sanity", total=0.5, weights={"a": 0.5, "b": 0.5},
                        components={"a": 0.4, "b": 0.6}, notes=("a note",)),
        stats=EpisodeStats(steps=400, invalid_actions=1, latency_ms_median=0.4,
                           latency_ms_p99=2.0, peak_memory_bytes=123456789, wall_s=12.5,
                           stage_durations_s={"explore": 5.0, "reach": 7.0}),
        stages_reached=("explore", "reach"), started_at=now, finished_at=now,
        episode_dir=f"/srv/eagc/runs/bench/ep{i:016x}",
        mcap=f"/srv/eagc/runs/bench/ep{i:016x}/host/episode.mcap")


def _fill(store: ResultsStore, n: int) -> None:
    """n committed rows in one transaction (the setup, not timed)."""
    rows = []
    for i in range(n):
        r = _result(i)
        rows.append(("bench", f"t{i % 8}", "standard", i, r.episode, r.status.value,
                     r.status.failure_kind, r.score.total, 0, "n", r.model_dump_json(), 0.0))
    store.db.execute("BEGIN")
    store.db.executemany("INSERT INTO episodes VALUES (?,?,?,?,?,?,?,?,?,?,?,?)", rows)
    store.db.execute("COMMIT")
    store.retally()
    store.db.execute("PRAGMA wal_checkpoint(TRUNCATE)")


class StoreRun:
    """The eagc store at ``size`` rows: ``run(n)`` times n commits + counts."""

    def __init__(self, folder: Path, size: int) -> None:
        self.store = ResultsStore(folder / f"store-{size}.sqlite")
        self.store.register(SPEC, "c0ffee", size)
        _fill(self.store, size)
        self.next = size

    def run(self, n: int) -> float:
        t = time.perf_counter()
        for i in range(self.next, self.next + n):
            self.store.commit("bench", EpisodeKey("t0", "standard", i), _result(i), retry=0,
                              node="n")
            self.store.counts("bench")
        self.next += n
        return time.perf_counter() - t

    def close(self) -> None:
        self.store.close()


#: What counts() did before the tallies (issue 13 §7): recount the campaign's rows.
_RECOUNT = ("SELECT status, COUNT(*) FROM episodes WHERE campaign=? GROUP BY status",
            "SELECT COUNT(*) FROM quarantine WHERE campaign=?",
            "SELECT COUNT(*) FROM attempts WHERE campaign=?")


class RecountRun(StoreRun):
    """The same commits, followed by the recount the driver used to do after each one."""

    def run(self, n: int) -> float:
        t = time.perf_counter()
        for i in range(self.next, self.next + n):
            self.store.commit("bench", EpisodeKey("t0", "standard", i), _result(i), retry=0,
                              node="n")
            for sql in _RECOUNT:
                self.store.db.execute(sql, ("bench",)).fetchall()
        self.next += n
        return time.perf_counter() - t


class BareRun:
    """Bare SQLite at ``size`` rows, same key, journal and sync: ``run(n)`` times n inserts,
    one transaction each."""

    def __init__(self, folder: Path, size: int) -> None:
        self.db = sqlite3.connect(folder / f"bare-{size}.sqlite", isolation_level=None)
        self.db.execute("PRAGMA journal_mode=WAL")
        self.db.execute("PRAGMA synchronous=FULL")
        self.db.execute("CREATE TABLE rows (campaign TEXT, submission TEXT, split TEXT, "
                        "idx INTEGER, episode TEXT UNIQUE, result TEXT, "
                        "PRIMARY KEY (campaign, submission, split, idx))")
        blob = _result(0).model_dump_json()
        self.db.execute("BEGIN")
        self.db.executemany("INSERT INTO rows VALUES (?,?,?,?,?,?)",
                            (("bench", f"t{i % 8}", "standard", i, f"ep{i}", blob)
                             for i in range(size)))
        self.db.execute("COMMIT")
        self.db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        self.next = size

    def run(self, n: int) -> float:
        t = time.perf_counter()
        for i in range(self.next, self.next + n):
            self.db.execute("BEGIN IMMEDIATE")
            self.db.execute("INSERT INTO rows VALUES (?,?,?,?,?,?)",
                            ("bench", "t0", "standard", i, f"ep{i}",
                             _result(i).model_dump_json()))
            self.db.execute("COMMIT")
        self.next += n
        return time.perf_counter() - t

    def close(self) -> None:
        self.db.close()


def measure(folder: Path, size: int, commits: int,
            rounds: int = 10) -> tuple[float, float, float]:
    """(eagc, bare, recount) commits/s, interleaved in ``rounds`` so that all see the same
    disk (the recount, slow at large sizes, gets a tenth of the commits)."""
    ours, bare = StoreRun(folder, size), BareRun(folder, size)
    (folder / f"store-{size}.sqlite").parent.joinpath("recount").mkdir(exist_ok=True)
    recount = RecountRun(folder / "recount", size)
    chunk = max(1, commits // rounds)
    small = max(1, chunk // 10)
    t_ours = t_bare = t_recount = 0.0
    for _ in range(rounds):
        t_ours += ours.run(chunk)
        t_bare += bare.run(chunk)
        t_recount += recount.run(small)
    for run in (ours, bare, recount):
        run.close()
    n = chunk * rounds
    return n / t_ours, n / t_bare, small * rounds / t_recount


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--commits", type=int, default=500)
    ap.add_argument("--sizes", default="1000,10000,100000")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    print(machine_line("pydantic", extra=f"sqlite {sqlite3.sqlite_version}"))
    print(f"load average before: {load_average()}")
    print(f"{args.commits} commits timed at each size; durable (WAL, synchronous=FULL)")
    print()
    print(f"{'rows in store':>13} {'eagc commit+counts/s':>21} {'bare insert/s':>14} "
          f"{'ratio':>6} {'before: +recount/s':>19}")
    with tempfile.TemporaryDirectory(prefix="eagc-bench-store-") as tmp:
        folder = Path(tmp)
        for size in sizes:
            ours, bare, before = measure(folder, size, args.commits)
            print(f"{size:>13,} {ours:>21,.0f} {bare:>14,.0f} {ours / bare:>6.2f} "
                  f"{before:>19,.0f}")
    print(f"\nload average after: {load_average()}")
    print("goal: >= 1,000 eagc commits/s at 100,000 rows")


if __name__ == "__main__":
    main()
