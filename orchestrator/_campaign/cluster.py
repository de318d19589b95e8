"""The Ray cluster a campaign runs on, as its driver sees it.

``ray_connection`` connects to an existing cluster (``--address``, which must answer
within seconds) or starts an embedded one of the campaign's own, with Ray's token
authentication configured; every node offers ``SLOT``, one per container it may run at a
time. ``ClusterWatch`` notices a lost cluster within seconds (Ray itself would after 60 s,
then abort the process without the driver's cleanup) and waits for Ray calls in slices, so
that none of them can hold the driver once the cluster is gone: ``ClusterLost``.
"""

from __future__ import annotations

import logging
import math
import os
import socket
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

from orchestrator._campaign.driver_io import EXIT_CLUSTER, CampaignError, DriverFailure
from schemas import CampaignSpec

if TYPE_CHECKING:
    from orchestrator._campaign.driver_io import CampaignOptions

log = logging.getLogger("eagc.campaign")

#: The Ray resource a node offers per container it may run at a time.
SLOT = "eagc_slot"


class ClusterLost(CampaignError):
    """Raised when the Ray cluster (its GCS, or this node's raylet) stopped answering while
    a campaign ran."""


def _token_auth() -> None:
    """Ray token authentication, configured rather than defaulted: with ``RAY_AUTH_MODE``
    unset, Ray 2.60 turns it on by itself and warns on every campaign. An operator who wants
    it off sets ``RAY_AUTH_MODE=disabled`` (and the cluster must agree)."""
    if "RAY_AUTH_MODE" in os.environ:
        return
    os.environ["RAY_AUTH_MODE"] = "token"
    try:  # the process's Ray config was read at import: read it again, as Ray itself does
        from ray._raylet import Config

        Config.initialize("")
    except Exception as e:  # noqa: BLE001 - an older Ray without token authentication
        log.debug("Ray config not re-read: %s", e)


def _reachable(address: str, patience_s: float = 10.0) -> None:
    """A ``host:port`` address must answer within ``patience_s``: Ray itself would retry an
    unreachable GCS for minutes, printing a warning every few seconds. ``auto`` and
    ``ray://`` addresses are left to Ray."""
    if address == "auto" or "://" in address or ":" not in address:
        return
    host, _, port = address.rpartition(":")
    if not port.isdigit():
        raise CampaignError(f"--address {address!r}: expected HOST:PORT of a Ray head "
                            "(its GCS port, 6379 by default)")
    deadline = time.monotonic() + patience_s
    while True:
        try:
            with socket.create_connection((host or "127.0.0.1", int(port)), timeout=2.0):
                return
        except OSError as e:
            if time.monotonic() > deadline:
                raise DriverFailure(
                    f"no Ray cluster answers at {address} ({e.strerror or e}): start its "
                    f"head (`ray start --head --port {port} --resources "
                    "'{\"eagc_slot\": N}'`) or correct --address; nothing was run",
                    EXIT_CLUSTER) from None
            time.sleep(0.5)


@contextmanager
def ray_connection(spec: CampaignSpec, options: CampaignOptions) -> Iterator[None]:
    """An existing cluster (``address``), the Ray already initialized, or an embedded one.

    The embedded Ray is always a new cluster of its own (``address="local"``: never one
    that ``ray start`` left on the machine) in its own temp dir under ``$RAY_TMPDIR`` (or
    /tmp), removed when the campaign ends; should the driver be killed, a sentinel process
    (``orchestrator._programs.ray_sentinel``) ends what is left of that Ray and removes the dir.
    """
    import shutil
    import tempfile

    import ray

    from orchestrator._programs import ray_sentinel as raysentinel

    owned = not ray.is_initialized()
    temp: str | None = None
    if owned:
        _token_auth()
        quiet: dict[str, Any] = {"log_to_driver": False, "logging_level": logging.WARNING,
                                 "namespace": "eagc"}
        if options.address:
            _reachable(options.address)
            ray.init(address=options.address, **quiet)
        else:
            cpus = max(os.cpu_count() or 1, math.ceil(options.workers * spec.limits.cpus))
            temp = tempfile.mkdtemp(prefix="eagc-ray-",
                                    dir=os.environ.get("RAY_TMPDIR") or "/tmp")
            ray.init(address="local", num_cpus=cpus, resources={SLOT: float(options.workers)},
                     include_dashboard=False, _temp_dir=temp, **quiet)
            # Should this driver be killed, what it started of Ray goes with it.
            raysentinel.start(os.getpid(), temp)
    lost = False
    try:
        if not ray.cluster_resources().get(SLOT):
            raise CampaignError(f"no Ray node offers the {SLOT!r} resource: start nodes with "
                                f"`ray start … --resources '{{\"{SLOT}\": N}}'` (N containers "
                                "at a time on that node)")
        yield
    except ClusterLost:
        lost = True
        raise
    except DriverFailure as e:
        lost = e.exit_code == EXIT_CLUSTER
        raise
    finally:
        if owned and not lost:  # with the GCS gone, shutdown() would wait for it
            ray.shutdown()
        if temp is not None and not lost:
            shutil.rmtree(temp, ignore_errors=True)


class ClusterWatch:
    """Watches, from a thread of its own, the two things a driver cannot go on without: the
    GCS and this node's raylet. ``lost`` is set once this node's raylet refused connections
    twice in a row (a raylet never comes back: a new one is a new node) or the GCS refused
    for ``patience_s`` in a row (a GCS with fault tolerance may restart). Ray itself would
    notice only after 60 s, and then abort the process without the driver's cleanup.

    The driver's main thread ``claim``s a loss it noticed and runs its failure path. Should
    it not within ``grace_s`` (stuck in a Ray call that waits for the dead GCS, as
    ``ray.nodes()`` does until Ray's own abort), the watch's thread claims it and calls
    ``on_stuck``, which ends the campaign without Ray.
    """

    def __init__(self, gcs: str, patience_s: float, *, raylet: tuple[str, int] | None = None,
                 interval_s: float = 0.5, grace_s: float = 5.0,
                 on_stuck: Callable[[], None] | None = None) -> None:
        host, _, port = gcs.rpartition(":")
        self.target = (host or "127.0.0.1", int(port))
        self.patience_s = patience_s
        self.interval_s = interval_s
        self.grace_s = grace_s
        self.on_stuck = on_stuck
        # A raylet is watched only once it answered: a firewall that refuses us is no loss.
        self.raylet = raylet if raylet is not None and _answers(raylet, 1.0) else None
        self.reason = ""
        self.lost = threading.Event()
        self._stop = threading.Event()
        self._claim = threading.Lock()
        self._claimed = False
        self._thread = threading.Thread(target=self._run, daemon=True, name="eagc-gcs-watch")
        self._thread.start()

    def alive(self, timeout: float = 1.0) -> bool:
        """Whether the GCS accepts a connection within ``timeout`` seconds."""
        return _answers(self.target, timeout)

    def confirm(self, settle_s: float = 1.0) -> bool:
        """After a task failed: whether the cluster is still there, asked twice ``settle_s``
        apart (a cluster that is being killed may still answer for a moment). False, and
        ``lost`` set, if the GCS or this node's raylet did not answer either time."""
        for i in range(2):
            if i:
                time.sleep(settle_s)
            if self._raylet_refused():
                self.mark_lost(f"this node's raylet at {self._at(self.raylet)} is gone")
                return False
            if not self.alive(timeout=2.0):
                self.mark_lost(f"its GCS at {self._at(self.target)} stopped answering")
                return False
        return True

    def claim(self) -> bool:
        """True for the first caller after a loss (it runs the failure path), else False."""
        with self._claim:
            first, self._claimed = not self._claimed, True
            return first

    def error(self) -> ClusterLost:
        """The loss, as the exception that says so."""
        return ClusterLost(f"the Ray cluster stopped answering ({self.reason})")

    def check(self) -> None:
        """ClusterLost once the cluster is lost: the caller runs the failure path, unless the
        watch's own thread claimed the loss first (``on_stuck`` then ends the process)."""
        if not self.lost.is_set():
            return
        if not self.claim():
            threading.Event().wait()
        raise self.error()

    def call(self, fn: Callable[..., Any], *args: Any, timeout_s: float | None = None) -> Any:
        """``fn(*args)``, a Ray call that may wait for the GCS as long as Ray retries it
        (``ray.nodes()`` does, until Ray's own abort after 60 s), run on a thread of its own
        and waited for in slices: ClusterLost (``check``) as soon as the cluster is lost,
        TimeoutError after ``timeout_s``. A thread left waiting ends with the process."""
        box: dict[str, Any] = {}

        def run() -> None:
            try:
                box["value"] = fn(*args)
            except BaseException as e:  # noqa: BLE001 - raised again in the caller's thread
                box["error"] = e

        thread = threading.Thread(target=run, daemon=True, name="eagc-ray-call")
        thread.start()
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        while thread.is_alive():
            thread.join(0.5)
            self.check()
            if deadline is not None and thread.is_alive() and time.monotonic() > deadline:
                raise TimeoutError(f"{getattr(fn, '__name__', fn)} took over {timeout_s:g} s")
        if "error" in box:
            raise box["error"]
        return box.get("value")

    def get(self, ref: Any, timeout_s: float) -> Any:
        """``ray.get(ref)`` within ``timeout_s`` (GetTimeoutError), waited for in slices so
        that a lost cluster is noticed meanwhile (ClusterLost, ``check``)."""
        import ray

        deadline = time.monotonic() + timeout_s
        while not ray.wait([ref], timeout=min(0.5, max(0.0, deadline - time.monotonic())))[0]:
            self.check()
            if time.monotonic() >= deadline:
                raise ray.exceptions.GetTimeoutError(f"no answer within {timeout_s:g} s")
        return ray.get(ref)

    def _raylet_refused(self) -> bool:
        if self.raylet is None:
            return False
        try:
            with socket.create_connection(self.raylet, timeout=1.0):
                return False
        except ConnectionRefusedError:
            return True
        except OSError:  # a timeout on a loaded machine is no verdict
            return False

    def mark_lost(self, reason: str) -> None:
        """Sets ``lost`` with its reason (the first one given)."""
        if not self.lost.is_set():
            self.reason = reason
            self.lost.set()

    @staticmethod
    def _at(target: tuple[str, int] | None) -> str:
        return "?" if target is None else f"{target[0]}:{target[1]}"

    def _run(self) -> None:
        last_ok = time.monotonic()
        refused = 0
        while not self.lost.is_set() and not self._stop.wait(self.interval_s):
            refused = refused + 1 if self._raylet_refused() else 0
            if refused >= 2:
                self.mark_lost(f"this node's raylet at {self._at(self.raylet)} is gone")
            elif self.alive():
                last_ok = time.monotonic()
            elif time.monotonic() - last_ok > self.patience_s:
                self.mark_lost(f"its GCS at {self._at(self.target)} refused connections for "
                               f"{self.patience_s:g} s")
        if self.lost.is_set() and not self._stop.wait(self.grace_s) and self.on_stuck:
            if self.claim():  # the main thread did not notice: it waits in Ray
                self.on_stuck()

    def close(self) -> None:
        self._stop.set()


def _answers(target: tuple[str, int], timeout: float) -> bool:
    try:
        with socket.create_connection(target, timeout=timeout):
            return True
    except OSError:
        return False
