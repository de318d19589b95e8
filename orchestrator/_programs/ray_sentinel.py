"""The embedded Ray's sentinel: what a killed driver leaves of its Ray goes with it.

    python ray_sentinel.py DRIVER_PID TEMP_DIR

A driver that starts an embedded Ray (``orchestrator._campaign.cluster.ray_connection``) gives it a
temp dir of its own and starts this sentinel in a session of its own. When the driver ends
cleanly it shuts Ray down and removes the dir itself, and the sentinel finds nothing to do.
When the driver is killed (SIGKILL, OOM), Ray's GCS and raylet follow it, but its dashboard
and runtime-env agents were seen to live on for 2-5 minutes, holding the session's logs.
The sentinel then ends every process that still has the temp dir open, as its working
folder or on its command line, and removes the dir.

A plain script on purpose: only the standard library, no eagc import, so that it starts in
a few milliseconds and depends on nothing the driver had loaded. It touches only processes
that name the driver's unique temp dir.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time

POLL_S = 0.5
SWEEP_S = 20.0


def _started(pid: int) -> str | None:
    """The process's start time (field 22 of /proc/PID/stat), so a reused pid is not it."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[19]
    except (OSError, IndexError):
        return None


def _holds(pid: int, folder: str) -> bool:
    """Whether a process names ``folder`` on its command line, or has it open or as cwd."""
    base = f"/proc/{pid}"
    inside = folder + "/"
    try:
        with open(f"{base}/cmdline", "rb") as f:
            cmd = f.read()
        if inside.encode() in cmd or (folder + "\0").encode() in cmd:
            return True
        if (os.readlink(f"{base}/cwd") + "/").startswith(inside):
            return True
        for fd in os.listdir(f"{base}/fd"):
            try:
                if (os.readlink(f"{base}/fd/{fd}") + "/").startswith(inside):
                    return True
            except OSError:
                continue
    except OSError:
        return False
    return False


def sweep(folder: str) -> int:
    """Kills every other process that holds ``folder``; returns how many it found."""
    me = os.getpid()
    found = 0
    for name in os.listdir("/proc"):
        if name.isdigit() and int(name) != me and _holds(int(name), folder):
            found += 1
            try:
                os.kill(int(name), signal.SIGKILL)
            except OSError:
                pass
    return found


def guard(driver: int, folder: str) -> None:
    """Waits for ``driver`` to end, then sweeps ``folder``'s processes and removes it."""
    born = _started(driver)
    while born is not None and _started(driver) == born:
        time.sleep(POLL_S)
    deadline = time.monotonic() + SWEEP_S
    quiet = 0
    while time.monotonic() < deadline and quiet < 2:  # twice in a row: nothing restarted
        quiet = quiet + 1 if sweep(folder) == 0 else 0
        time.sleep(POLL_S)
    shutil.rmtree(folder, ignore_errors=True)


def start(driver: int, folder: str) -> None:
    """Starts the sentinel of ``driver``'s embedded Ray in ``folder`` (returns at once)."""
    subprocess.Popen([sys.executable, "-S", os.path.abspath(__file__), str(driver), folder],
                     stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                     stderr=subprocess.DEVNULL, start_new_session=True, close_fds=True)


def main(argv: list[str]) -> int:
    if len(argv) != 2 or not argv[0].isdigit() or not os.path.isabs(argv[1]):
        print(__doc__, file=sys.stderr)
        return 2
    guard(int(argv[0]), os.path.realpath(argv[1]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
