"""What a campaign's driver takes and leaves, apart from Ray.

``CampaignOptions`` (how to run; the spec says what) in, ``CampaignReport`` (what the run
did) out. A run that had to stop raises ``DriverFailure`` with its exit code (``EXIT_STORE``
5, ``EXIT_CLUSTER`` 6) after the cancel path ran; every campaign error derives from
``CampaignError``. In the campaign's folder the driver keeps ``events.jsonl`` (``Events``:
what it saw, no seeds) and ``driver.lock`` (``driver_lock``: one driver per campaign).
SIGTERM cancels like Ctrl-C (``sigterm_as_interrupt``).
"""

from __future__ import annotations

import fcntl
import logging
import os
import signal
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from orchestrator._errors import OrchestratorError
from schemas import CampaignEvent, event_line

log = logging.getLogger("eagc.campaign")


class CampaignError(OrchestratorError, RuntimeError):
    """Raised when a campaign cannot start: images, the cluster, another driver, the store."""


class DriverFailure(CampaignError):
    """Raised when a running campaign had to stop (its store failed, the Ray cluster was
    lost): the cancel path ran and every committed result is kept."""

    def __init__(self, message: str, exit_code: int) -> None:
        super().__init__(message)
        self.exit_code = exit_code


#: Exit codes of ``eagc campaign run`` for a campaign that had to stop (``ExitCode``).
EXIT_STORE, EXIT_CLUSTER = 5, 6


@dataclass(frozen=True)
class CampaignOptions:
    """How to run a campaign (the spec says what to run)."""

    address: str | None = None
    workers: int = 1
    metrics_port: int | None = None
    metrics_addr: str = "0.0.0.0"
    #: Keep serving metrics this long after the campaign (Prometheus takes a last scrape).
    metrics_linger_s: float = 0.0
    progress: bool = True
    retry_quarantined: bool = False
    cancel_grace_s: float = 20.0
    #: How long the GCS may refuse connections before the campaign is given up.
    cluster_patience_s: float = 10.0


@dataclass
class CampaignReport:
    """What one driver run did."""

    campaign: str
    planned: int
    skipped: int = 0
    committed: int = 0
    duplicates: int = 0
    retries: int = 0
    quarantined: int = 0
    cancelled: bool = False
    wall_s: float = 0.0
    commit_s: list[float] = field(default_factory=list)
    nodes: set[str] = field(default_factory=set)
    metrics_port: int | None = None
    reaped: int = 0


class Events:
    """``events.jsonl``: what the driver saw, one JSON object a line (no seeds)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._f: IO[str] = path.open("a")

    def write(self, event: CampaignEvent) -> None:
        """Appends one event; StoreWriteError if it could not be written (a full disk):
        ``rebuild-store`` needs these lines as much as the store needs its rows."""
        from orchestrator._results.store import StoreWriteError

        try:
            self._f.write(event_line(event))
            self._f.flush()
        except OSError as e:
            raise StoreWriteError(f"could not write {self.path}: {e.strerror or e}") from None

    def try_write(self, event: CampaignEvent) -> None:
        """``write`` on the way out of a failed campaign: a failure is only logged."""
        try:
            self.write(event)
        except Exception as e:  # noqa: BLE001
            log.warning("%s", e)

    def close(self) -> None:
        try:
            self._f.close()
        except OSError as e:  # the last buffered bytes did not fit on the disk
            log.warning("closing %s: %s", self.path, e)


@contextmanager
def driver_lock(folder: Path) -> Iterator[None]:
    """One driver per campaign (the lock goes with the process, even on SIGKILL)."""
    folder.mkdir(parents=True, exist_ok=True)
    with (folder / "driver.lock").open("a+") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            f.seek(0)
            raise CampaignError(f"another driver runs this campaign (pid {f.read().strip()}); "
                                f"lock: {folder / 'driver.lock'}") from None
        f.truncate(0)
        f.write(str(os.getpid()))
        f.flush()
        yield


@contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM cancels like Ctrl-C (main thread only)."""
    def raise_interrupt(*_: object) -> None:
        raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGTERM, raise_interrupt)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
