"""CPU placement: an agent's container on cores apart from its sim host's.

A placement is one core for the sim host and ``ceil(limits.cpus)`` cores for the agent. An
episode claims a free placement for as long as its host and agent run: a file lock per core
(``EAGC_LOCK_DIR``, default ``/tmp``), so concurrent episodes on one machine never share a
core, even when they run in different Ray nodes or with different limits. While it holds
one, every thread of the worker process runs on the host core and the container gets the
agent cores as its cpuset; the process's affinity is restored afterwards.

"Where possible": a machine with too few free cores gives no placement and the episode runs
unpinned (the CPU quota still holds), which the episode's log records.
"""

from __future__ import annotations

import fcntl
import logging
import math
import os
import threading
from collections.abc import Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path

log = logging.getLogger("eagc.cpus")
_PINNING = threading.Lock()  # one placement at a time pins this process's threads


@dataclass(frozen=True)
class Placement:
    """Disjoint cores for one episode's sim host and agent."""

    host: tuple[int, ...]
    agent: tuple[int, ...]

    @property
    def cpuset(self) -> str:
        """The agent's cores in the form Docker's ``cpuset_cpus`` takes ("1,2")."""
        return ",".join(map(str, self.agent))

    def as_dict(self) -> dict[str, list[int]]:
        return {"host": list(self.host), "agent": list(self.agent)}


def plan(cpus: Sequence[int], agent_cpus: float) -> list[Placement]:
    """Every placement the cores allow, in order, none sharing a core."""
    per = math.ceil(agent_cpus) + 1
    cores = sorted(cpus)
    return [
        Placement(host=(cores[i],), agent=tuple(cores[i + 1 : i + per]))
        for i in range(0, len(cores) - per + 1, per)
    ]


def _lock_dir() -> Path:
    return Path(os.environ.get("EAGC_LOCK_DIR", "/tmp"))


def _try_lock(stack: ExitStack, core: int, folder: Path) -> bool:
    f = stack.enter_context((folder / f"eagc-cpu-{core}.lock").open("a"))
    try:
        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    stack.callback(fcntl.flock, f, fcntl.LOCK_UN)
    return True


def _claim(placement: Placement, folder: Path) -> ExitStack | None:
    stack = ExitStack()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for core in (*placement.host, *placement.agent):
            if not _try_lock(stack, core, folder):
                stack.close()
                return None
    except OSError as e:  # an unwritable lock folder: no placement rather than no episode
        log.warning("cannot lock cores in %s: %s", folder, e)
        stack.close()
        return None
    return stack


def _pin_process(cores: set[int]) -> None:
    """Every thread of this process (the affinity call acts on one thread at a time)."""
    for tid in os.listdir("/proc/self/task"):
        try:
            os.sched_setaffinity(int(tid), cores)
        except OSError:  # the thread ended meanwhile
            pass


@contextmanager
def placed(
    agent_cpus: float, *, enabled: bool = True, cpus: Sequence[int] | None = None
) -> Iterator[Placement | None]:
    """Claims a free placement and pins this process to its host core while it is held.

    ``cpus``: the cores to place on (default: those this thread may use). Yields None (and
    pins nothing) when disabled, when the platform has no affinity calls, or when no
    placement is free.
    """
    if not enabled or not hasattr(os, "sched_getaffinity"):
        yield None
        return
    before = os.sched_getaffinity(0)
    folder = _lock_dir()
    for placement in plan(before if cpus is None else cpus, agent_cpus):
        held = _claim(placement, folder)
        if held is None:
            continue
        with held:
            # Two episodes in one process (tests, threads) cannot both own its threads:
            # the second keeps its agent apart but leaves the process as it is.
            pin = _PINNING.acquire(blocking=False)
            try:
                if pin:
                    _pin_process(set(placement.host))
                yield placement
            finally:
                if pin:
                    _pin_process(before)
                    _PINNING.release()
        return
    log.info("no free cores for a placement (%d usable, agent asks %.1f): running unpinned",
             len(before), agent_cpus)
    yield None
