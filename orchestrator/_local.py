"""``LocalProcessRuntime``: the agent as a plain process. DEVELOPMENT ONLY.

No sandbox at all: the agent has the network, the whole filesystem and no resource limits
beyond an address-space cap. Never use it for official runs; campaigns refuse it outside
the ``local`` phase.
"""

from __future__ import annotations

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
from pathlib import Path

from orchestrator._runtime import (
    AgentHandle,
    AgentLaunch,
    AgentRuntime,
    AgentStartError,
    sample_interval,
)
from schemas import ContainerExit

log = logging.getLogger("eagc.local")

WARNING = (
    "LocalProcessRuntime: the agent runs as a plain process WITHOUT the sandbox "
    "(network, files and memory are not isolated). Development only, never for official runs."
)


class LocalAgent(AgentHandle):
    def __init__(self, proc: subprocess.Popen[bytes]) -> None:
        self.proc = proc
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
        memory = launch.limits.memory_mb * 1024 * 1024
        cores = {int(c) for c in launch.cpuset.split(",")} if launch.cpuset else set()

        def limits() -> None:  # runs in the child before exec
            # Address space, not resident memory: generous, but stops a runaway process.
            resource.setrlimit(resource.RLIMIT_AS, (memory * 4, memory * 4))
            if cores:  # the worker's thread may be pinned to the sim host's core
                os.sched_setaffinity(0, cores)

        try:
            proc = subprocess.Popen(
                argv,
                env=env,
                cwd=Path.cwd(),
                stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT,
                start_new_session=True,
                preexec_fn=limits,
            )
        except (OSError, ValueError) as e:
            raise AgentStartError(f"cannot start {launch.image!r}: {e}") from e
        return LocalAgent(proc)
