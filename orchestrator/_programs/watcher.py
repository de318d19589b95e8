"""The episode watcher: one small process per Docker episode (``orchestrator._runtimes.reaper``).

    python watcher.py CONTAINER HEARTBEAT DEADLINE STALE_S POLL_S

Forks, and the parent leaves at once (so the worker that started it waits for one
interpreter start only, and the watcher is re-parented to init: neither a killed worker nor
a killed Ray takes it along). The child polls the container every ``POLL_S`` until it is
gone, and removes it when its heartbeat is older than ``STALE_S`` or gone (no worker looks
after the episode any more), or at ``DEADLINE`` (Unix time; the episode's hard deadline).

A plain script on purpose: only the standard library at start and the docker SDK in the
child, no eagc import.
"""

from __future__ import annotations

import os
import sys
import time


def watch(container: str, heartbeat: str, deadline: float, stale_s: float,
          poll_s: float) -> str:
    """Polls ``container`` until it is gone or removed; returns why it stopped."""
    import docker

    client = docker.from_env(timeout=60)
    while True:
        try:
            c = client.containers.get(container)
        except docker.errors.NotFound:
            return "gone"
        except Exception:  # noqa: BLE001 - the engine restarts: try again
            time.sleep(poll_s)
            continue
        try:
            age: float | None = time.time() - os.stat(heartbeat).st_mtime
        except OSError:
            age = None
        why = None
        if time.time() >= deadline:
            why = "its hard deadline passed"
        elif age is None:
            why = "its episode's heartbeat is gone"
        elif age >= stale_s:
            why = f"its episode's heartbeat is {age:.0f} s old"
        if why is not None:
            try:
                c.remove(force=True)
            except Exception:  # noqa: BLE001 - gone meanwhile
                pass
            return f"removed: {why}"
        time.sleep(poll_s)


def main(argv: list[str]) -> int:
    if len(argv) != 5:
        print(__doc__, file=sys.stderr)
        return 2
    if os.fork() != 0:
        return 0
    os.setsid()
    devnull = os.open(os.devnull, os.O_RDWR)
    for fd in (0, 1, 2):
        os.dup2(devnull, fd)
    watch(argv[0], argv[1], float(argv[2]), float(argv[3]), float(argv[4]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
