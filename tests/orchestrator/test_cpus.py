"""CPU placement: the agent's cores apart from its sim host's, claimed machine-wide."""

from __future__ import annotations

import os
import sys
import threading
from pathlib import Path

import pytest

from orchestrator._runtimes.cpus import Placement, placed, plan
from orchestrator._runtimes.interface import AgentLaunch
from orchestrator._runtimes.local import LocalProcessRuntime
from schemas import Limits

CORES = sorted(os.sched_getaffinity(0))


@pytest.fixture(autouse=True)
def _locks(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("EAGC_LOCK_DIR", str(tmp_path))  # apart from any real episode's


def test_plan_gives_disjoint_placements() -> None:
    assert plan([0, 1], 1.0) == [Placement(host=(0,), agent=(1,))]
    assert plan([3, 2, 1, 0], 1.0) == [Placement((0,), (1,)), Placement((2,), (3,))]
    assert plan([0, 1, 2, 3, 4], 2.0) == [Placement((0,), (1, 2))]
    assert plan([0, 1, 2, 3], 1.5) == [Placement((0,), (1, 2))]
    assert plan([0], 1.0) == []
    assert Placement((0,), (1, 2)).cpuset == "1,2"


def test_one_placement_per_core_and_the_process_pinned_meanwhile() -> None:
    if len(CORES) < 2:  # explicit: a one-core machine has no placement to give
        with placed(1.0) as p:
            assert p is None
        return
    cores = CORES[:2]
    stop = threading.Event()
    older = threading.Thread(target=stop.wait)  # a thread that exists before the claim
    older.start()
    try:
        with placed(1.0, cpus=cores) as first:
            assert first == Placement((cores[0],), (cores[1],))
            assert os.sched_getaffinity(0) == {cores[0]}
            assert older.native_id is not None
            assert os.sched_getaffinity(older.native_id) == {cores[0]}
            with placed(1.0, cpus=cores) as second:  # the cores are taken
                assert second is None
                assert os.sched_getaffinity(0) == {cores[0]}
        assert os.sched_getaffinity(0) == set(CORES)
        assert os.sched_getaffinity(older.native_id) == set(CORES)
        with placed(1.0, cpus=cores) as again:  # released
            assert again == first
    finally:
        stop.set()
        older.join()


def test_disabled_places_nothing() -> None:
    with placed(1.0, enabled=False) as p:
        assert p is None
        assert os.sched_getaffinity(0) == set(CORES)


def test_the_local_agent_runs_on_its_cores(tmp_path: Path) -> None:
    core = CORES[-1]
    launch = AgentLaunch(
        image=f"{sys.executable} -c 'import os; print(sorted(os.sched_getaffinity(0)))'",
        episode="cpus", socket_dir=tmp_path, output_dir=tmp_path, limits=Limits(),
        cpuset=str(core),
    )
    with placed(1.0, cpus=CORES[:2]):  # the worker pinned elsewhere must not matter
        handle = LocalProcessRuntime(quiet=True).start(launch)
        assert handle.wait(30)
    exit_ = handle.stop()
    assert exit_.exit_code == 0, exit_.log_tail
    assert exit_.log_tail.strip() == str([core])
