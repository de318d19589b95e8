"""What every benchmark prints about the machine, and how its children die with it."""

from __future__ import annotations

import contextlib
import ctypes
import importlib.metadata
import json
import os
import platform
import signal
import subprocess
from pathlib import Path


def load_average() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "?"


def version(dist: str) -> str:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return "?"


def machine_line(*dists: str, extra: str = "") -> str:
    """``machine: nproc=2 (cpu model), python 3.11.7, <dist> <version>…, Linux <release>``."""
    model = ""
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    parts = [f"machine: nproc={len(os.sched_getaffinity(0))} ({model or platform.machine()})",
             f"python {platform.python_version()}"]
    parts += [f"{d} {version(d)}" for d in dists]
    parts.append(f"{platform.system()} {platform.release()}")
    if extra:
        parts.append(extra)
    return ", ".join(parts)


def die_with_parent() -> None:
    """Linux: SIGKILL this child when the orchestrating parent goes away."""
    with contextlib.suppress(Exception):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    if os.getppid() == 1:
        os._exit(1)


def reap(procs: list[subprocess.Popen[bytes]]) -> None:
    """Kills every child still running, waits for each (5 s at most) and closes its pipes;
    empties ``procs``."""
    for p in procs:
        if p.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                p.kill()
    for p in procs:
        with contextlib.suppress(Exception):
            p.wait(timeout=5)
        for f in (p.stdout, p.stderr):
            if f is not None:
                f.close()
    procs.clear()


def run_child(argv: list[str], procs: list[subprocess.Popen[bytes]], *, env: dict[str, str],
              cwd: Path, timeout_s: float) -> dict:
    """Runs one benchmark child to its end and returns the JSON of its last stdout line;
    RuntimeError (with its stderr's tail) when it fails or outlives ``timeout_s``. The child
    is in ``procs`` while it runs, so that an interrupted run reaps it."""
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         stdin=subprocess.DEVNULL, env=env, cwd=str(cwd))
    procs.append(p)
    try:
        out, err = p.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        raise RuntimeError(f"timed out after {timeout_s:.0f} s") from None
    finally:
        reap(procs)
    if p.returncode != 0:
        raise RuntimeError(f"rc {p.returncode}:\n{err.decode(errors='replace')[-2000:]}")
    return dict(json.loads(out.decode().strip().splitlines()[-1]))
