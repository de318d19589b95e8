"""Nothing an episode starts outlives it: heartbeats, the reaper and the episode watcher.

Ray cannot reach a container owned by the Docker daemon, so a worker that dies (killed, its
node lost, the whole Ray gone with its driver) leaves its agent container running. Three
things bound it, each from outside the container:

* **Heartbeat.** While an episode runs, its worker touches ``<episode>/heartbeat`` every
  ``BEAT_S``; the container carries the file's path in its ``eagc.heartbeat`` label. A
  heartbeat older than ``STALE_S`` means that no worker looks after the episode any more.
* **Reaper.** Every worker, when it starts an episode and then every ``REAP_S`` while it
  runs one, removes the containers whose heartbeat it can read and that went stale. A
  container whose heartbeat it cannot read (another machine's folder, or no label at all)
  is never touched, so campaigns and tests with folders of their own never remove each
  other's live containers.
* **Episode watcher.** A small process of its own per Docker episode (not a child of the
  Ray worker: it is re-parented to init, so neither a killed worker nor a killed Ray takes
  it along) polls its one container: it removes it when the heartbeat went stale or
  vanished, or at the hard deadline (the sum of the stage budgets plus startup and grace),
  and exits as soon as the container is gone. This is what bounds a dead driver's
  containers when no worker is left: within ``STALE_S`` + ``POLL_S`` (about 35 s).

The watcher is ``orchestrator/_programs/watcher.py``, started by ``start_watcher``.
"""

from __future__ import annotations

import logging
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from orchestrator._runtimes.engine import managed_containers
from orchestrator._runtimes.interface import LABEL_PREFIX

log = logging.getLogger("eagc.reaper")

#: A heartbeat this old means a dead episode (``EAGC_HEARTBEAT_STALE_S``: tests shorten it).
STALE_S = float(os.environ.get("EAGC_HEARTBEAT_STALE_S", "30"))
BEAT_S = min(2.0, STALE_S / 3)
REAP_S = 30.0
POLL_S = min(2.0, STALE_S / 3)
HEARTBEAT_LABEL = f"{LABEL_PREFIX}.heartbeat"


def heartbeat_age(path: str | Path, now: float | None = None) -> float | None:
    """Seconds since the heartbeat at ``path`` was touched; None if it cannot be read."""
    try:
        mtime = os.stat(path).st_mtime
    except OSError:
        return None
    return (time.time() if now is None else now) - mtime


class Heartbeat:
    """Touches ``path`` every ``BEAT_S`` from a thread, and calls ``reap`` every ``REAP_S``.

    ``stop()`` removes the file: an episode that ended normally has no heartbeat left.
    """

    def __init__(self, path: Path, *, reap: Callable[[], int] | None = None) -> None:
        self.path = path
        self.reaped = 0
        self._reap = reap
        self._stop = threading.Event()
        self.path.touch()
        self._thread = threading.Thread(target=self._run, daemon=True,
                                        name=f"heartbeat-{path.parent.name}")
        self._thread.start()

    def _run(self) -> None:
        last_reap = time.monotonic()
        while not self._stop.wait(BEAT_S):
            try:
                os.utime(self.path)
            except OSError:  # the folder went away: nothing left to look after
                return
            if self._reap is not None and time.monotonic() - last_reap >= REAP_S:
                last_reap = time.monotonic()
                try:
                    self.reaped += self._reap()
                except Exception as e:  # noqa: BLE001 - the engine hiccuped; next round
                    log.warning("reaping stale containers: %s", e)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self.path.unlink(missing_ok=True)


def reap_stale(client: Any, *, stale_s: float = STALE_S) -> list[str]:
    """Removes the eagc containers whose heartbeat this machine can read and that went
    stale; returns their names. Containers without a readable heartbeat are left alone."""
    removed = []
    now = time.time()
    for c in managed_containers(client, [f"{LABEL_PREFIX}.managed=true"]):
        path = (c.labels or {}).get(HEARTBEAT_LABEL)
        if not path:
            continue
        age = heartbeat_age(path, now)
        if age is None or age < stale_s:
            continue
        try:
            c.remove(force=True)
            removed.append(c.name)
            log.warning("removed %s: its episode's heartbeat is %.0f s old", c.name, age)
        except Exception as e:  # noqa: BLE001 - removed by someone else meanwhile
            log.debug("could not remove %s: %s", c.name, e)
    return removed


#: Containers this process reaped so far (the Ray task reports the difference).
reaped_here = 0


def reap_here() -> int:
    """``reap_stale`` on this node's engine; 0 if there is none."""
    global reaped_here
    from orchestrator._runtimes.engine import docker_client

    try:
        n = len(reap_stale(docker_client()))
    except Exception as e:  # noqa: BLE001 - no engine (a local-runtime node)
        log.debug("no reaping here: %s", e)
        return 0
    reaped_here += n
    return n


# ---------------------------------------------------------------------------- watcher
def start_watcher(container: str, heartbeat: Path, deadline: float) -> None:
    """Starts the episode watcher (``_programs/watcher.py``, run as a plain script: it imports
    nothing of eagc, so it costs one interpreter start), detached from this process: it
    forks once more and its parent leaves, so it is re-parented to init."""
    subprocess.run(
        [sys.executable, str(Path(__file__).parents[1] / "_programs" / "watcher.py"), container,
         str(heartbeat), repr(deadline), repr(STALE_S), repr(POLL_S)],
        check=False, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL, start_new_session=True, timeout=30)
