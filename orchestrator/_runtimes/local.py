"""``LocalProcessRuntime``: the agent as a plain process. DEVELOPMENT ONLY.

No sandbox at all: the agent has the network, the whole filesystem and no resource limits
beyond an address-space cap. Never use it for official runs; campaigns refuse it outside
the ``local`` phase.

An agent never outlives its worker: it runs in a process group of its own with a
parent-death signal (SIGKILL). Linux sends that signal when the *thread* that forked the
child ends, so each agent is spawned from a thread that lives until the agent is stopped.
Its environment carries ``EAGC_LOCAL_AGENT`` (its labels and heartbeat, as JSON), by which
``cleanup`` finds agents left behind anyway (a worker whose parent-death signal could not
be delivered, e.g. one started before this change).
"""

from __future__ import annotations

import ctypes
import logging
import os
import resource
import shlex
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from pathlib import Path

from pydantic import BaseModel, ConfigDict, ValidationError

from orchestrator._runtimes.interface import (
    AgentHandle,
    AgentLaunch,
    AgentRuntime,
    AgentStartError,
    sample_interval,
)
from schemas import ContainerExit

log = logging.getLogger("eagc.local")

#: The environment variable that marks a local agent (a ``LocalMark`` as JSON).
MARK = "EAGC_LOCAL_AGENT"
_PR_SET_PDEATHSIG = 1


class LocalMark(BaseModel):
    """What marks a local agent, in its environment (``MARK``): how ``cleanup`` finds it."""

    model_config = ConfigDict(frozen=True, extra="ignore")

    #: The launch's labels and its episode id (``episode``).
    labels: dict[str, str] = {}
    #: The episode's heartbeat file (None: none; ``orchestrator._runtimes.reaper``).
    heartbeat: str | None = None

    def matches(self, labels: Mapping[str, str]) -> bool:
        """True when the agent's labels include every one of ``labels``."""
        return all(self.labels.get(k) == v for k, v in labels.items())


def _die_with_parent(parent: int) -> None:
    """In the child before exec: SIGKILL when the spawning thread ends."""
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:  # the parent died before the signal was armed
        os._exit(1)


class _Spawner(threading.Thread):
    """Starts one agent and lives until it is stopped (the parent-death signal's anchor)."""

    def __init__(self, argv: list[str], kwargs: dict[str, object]) -> None:
        super().__init__(daemon=True, name="local-agent")
        self.argv, self.kwargs = argv, kwargs
        self.proc: subprocess.Popen[bytes] | None = None
        self.error: BaseException | None = None
        self.ready = threading.Event()
        self.release = threading.Event()

    def run(self) -> None:
        try:
            self.proc = subprocess.Popen(self.argv, **self.kwargs)  # type: ignore[call-overload]
        except BaseException as e:  # noqa: BLE001 - handed to the caller
            self.error = e
        self.ready.set()
        if self.proc is not None:
            self.release.wait()


WARNING = (
    "LocalProcessRuntime: the agent runs as a plain process WITHOUT the sandbox "
    "(network, files and memory are not isolated). Development only, never for official runs."
)


class LocalAgent(AgentHandle):
    def __init__(self, proc: subprocess.Popen[bytes], spawner: _Spawner | None = None) -> None:
        self.proc = proc
        self._spawner = spawner
        self.id = str(proc.pid)
        self._tail: deque[str] = deque(maxlen=40)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self._exit: ContainerExit | None = None
        self._lock = threading.Lock()
        # Peak resident memory of the agent's own process (VmHWM), sampled while it runs: the
        # worker's RUSAGE_CHILDREN would mix every agent this process ever started.
        self.peak: int | None = None
        threading.Thread(target=self._sample, daemon=True).start()

    def _sample(self) -> None:
        started = time.monotonic()
        while self.proc.poll() is None:
            self.checkpoint()
            time.sleep(sample_interval(time.monotonic() - started))

    def checkpoint(self) -> None:
        try:  # VmHWM: the process's high-water mark
            with open(f"/proc/{self.proc.pid}/status") as f:
                for line in f:
                    if line.startswith("VmHWM:"):
                        self.peak = max(self.peak or 0, int(line.split()[1]) * 1024)
        except (OSError, ValueError):
            pass

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in iter(self.proc.stdout.readline, b""):
            self._tail.append(line.decode("utf-8", errors="replace"))

    def wait(self, timeout: float | None) -> bool:
        try:
            self.proc.wait(timeout=timeout)
            return True
        except subprocess.TimeoutExpired:
            return False

    def stop(self) -> ContainerExit:
        with self._lock:
            if self._exit is not None:
                return self._exit
            killed = False
            if self.proc.poll() is None:
                killed = True
            try:  # the whole process group: nothing the agent started survives
                os.killpg(self.proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            self.proc.wait()
            if self._spawner is not None:
                self._spawner.release.set()
            self._reader.join(timeout=5)
            code = self.proc.returncode
            self._exit = ContainerExit(
                exit_code=code if code >= 0 else 128 - code,
                oom_killed=False,
                killed_by_host=killed,
                peak_memory_bytes=self.peak,
                log_tail="".join(self._tail)[-4000:],
            )
            return self._exit


class LocalProcessRuntime(AgentRuntime):
    """Runs ``image`` as a shell-split command line (e.g. ``python agent.py``)."""

    name = "local"
    official = False

    def __init__(self, *, quiet: bool = False) -> None:
        if not quiet:
            log.warning(WARNING)

    def start(self, launch: AgentLaunch) -> AgentHandle:
        argv = shlex.split(launch.image)
        if argv and argv[0] in ("python", "python3"):
            argv[0] = sys.executable
        env = dict(os.environ)
        env.update(
            launch.environment(
                socket_dir=str(launch.socket_dir),
                output_dir=str(launch.output_dir),
                input_dir=None if launch.input_dir is None else str(launch.input_dir),
            )
        )
        env["HOME"] = os.environ.get("HOME", "/tmp")
        env[MARK] = LocalMark(
            labels={"episode": launch.episode, **launch.labels},
            heartbeat=None if launch.heartbeat is None else str(launch.heartbeat),
        ).model_dump_json()
        memory = launch.limits.memory_mb * 1024 * 1024
        cores = {int(c) for c in launch.cpuset.split(",")} if launch.cpuset else set()

        parent = os.getpid()

        def limits() -> None:  # runs in the child before exec
            _die_with_parent(parent)
            # Address space, not resident memory: generous, but stops a runaway process.
            resource.setrlimit(resource.RLIMIT_AS, (memory * 4, memory * 4))
            if cores:  # the worker's thread may be pinned to the sim host's core
                os.sched_setaffinity(0, cores)

        spawner = _Spawner(argv, {
            "env": env, "cwd": Path.cwd(), "stdin": subprocess.DEVNULL,
            "stdout": subprocess.PIPE, "stderr": subprocess.STDOUT,
            "start_new_session": True, "preexec_fn": limits,
        })
        spawner.start()
        spawner.ready.wait()
        if spawner.proc is None:
            e = spawner.error
            if isinstance(e, (OSError, ValueError, subprocess.SubprocessError)):
                raise AgentStartError(f"cannot start {launch.image!r}: {e}") from e
            raise AgentStartError(f"cannot start {launch.image!r}: {e}")
        return LocalAgent(spawner.proc, spawner)

    def cleanup(self, labels: Mapping[str, str] | None = None) -> list[str]:
        """Kills the process groups of local agents whose labels include ``labels``."""
        return [f"pid {pid}" for pid, _ in kill_local_agents(labels or {})]


def local_agents() -> list[tuple[int, LocalMark]]:
    """(pid, mark) of every local agent on this machine that we may signal."""
    found = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            environ = (d / "environ").read_bytes()
        except OSError:
            continue
        for item in environ.split(b"\0"):
            if item.startswith(MARK.encode() + b"="):
                try:
                    found.append((int(d.name), LocalMark.model_validate_json(
                        item[len(MARK) + 1:])))
                except ValidationError:  # not a mark this eagc wrote
                    pass
                break
    return found


def kill_local_agents(labels: Mapping[str, str], *,
                      only: Callable[[LocalMark], bool] | None = None
                      ) -> list[tuple[int, LocalMark]]:
    """SIGKILLs the process group of each local agent matching ``labels`` (and ``only``)."""
    killed = []
    for pid, mark in local_agents():
        if not mark.matches(labels):
            continue
        if only is not None and not only(mark):
            continue
        try:
            os.killpg(os.getpgid(pid), signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            continue
        killed.append((pid, mark))
    return killed
