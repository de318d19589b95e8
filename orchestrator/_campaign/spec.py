"""Campaigns: the spec from YAML, the episode plan, pinned images, and the driver.

``run_campaign(spec)`` (in ``_driver``) plans every (submission, split, index), asks the
results store what is already there, and runs only the rest, one Ray task per episode,
interleaving the submissions so that they progress evenly. Results stream back with
``ray.wait`` and each is committed at once. A result whose status is ``infra_error``, or a
task whose worker died, is recorded as an attempt and run again with a new episode id, up
to ``spec.retries`` times; then the episode is quarantined (held back; the leaderboard
marks that submission's final as pending; ``--retry-quarantined`` runs it again once an
organizer decided so).
Agent failures are final. Ctrl-C (or SIGTERM) cancels the running tasks, removes this
campaign's containers on every node by label and keeps everything already committed.

Files (``output`` is resolved against the working directory, archives against the
campaign file's folder)::

    <output>/results.sqlite            the results store (any number of campaigns)
    <output>/<campaign>/events.jsonl   submitted / started / committed / retry / quarantined /
                                       cancelled / failed / finished
    <output>/<campaign>/driver.lock    one driver per campaign
    <output>/<campaign>/ep…/           episode folders (organizer side)

The output folder is created private (0700): episode folders hold the hidden scenario
(MCAP logs) and the seed commitment's inputs are derived there.

A campaign that cannot go on ends with one message, a distinct exit code and the cancel
path run (containers stopped, output mounts removed), keeping what was committed:
``StoreError`` (a damaged store refused at the start, a write that failed: a full disk) and
``ClusterLost`` (this node's raylet stopped answering, noticed within about a second, or
the Ray cluster's GCS, noticed within ``cluster_patience_s``; the driver leaves before Ray's
own 60 s abort, which would skip all of this, even when a Ray call of its own waits for the
dead GCS: ``ClusterWatch``). An episode in flight is charged a retry only when its own
node failed, never for a lost cluster or a failed store.
"""

from __future__ import annotations

import fcntl
import json
import logging
import math
import os
import signal
import socket
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from orchestrator._errors import OrchestratorError
from schemas import CampaignEvent, CampaignSpec, SchemaError, event_line, parse_json

log = logging.getLogger("eagc.campaign")

#: ``<runs>/ep<16 hex>/sock/zenoh.sock`` must fit the 100 bytes the worker allows.
MAX_RUNS_DIR = 100 - len("/ep0123456789abcdef/sock/zenoh.sock")


class CampaignError(OrchestratorError, RuntimeError):
    """Raised when a campaign cannot start: images, the cluster, another driver, the store."""


class ClusterLost(CampaignError):
    """Raised when the Ray cluster (its GCS, or this node's raylet) stopped answering while
    a campaign ran."""


class DriverFailure(CampaignError):
    """Raised when a running campaign had to stop (its store failed, the Ray cluster was
    lost): the cancel path ran and every committed result is kept."""

    def __init__(self, message: str, exit_code: int) -> None:
        super().__init__(message)
        self.exit_code = exit_code


#: The Ray resource a node offers per container it may run at a time.
SLOT = "eagc_slot"

#: Exit codes of ``eagc campaign run`` for a campaign that had to stop (``ExitCode``).
EXIT_STORE, EXIT_CLUSTER = 5, 6


# ---------------------------------------------------------------------------- the spec
def load_campaign(path: Path | str) -> CampaignSpec:
    """Reads and validates ``campaign.yaml``; SchemaError names the file and the field."""
    import yaml

    path = Path(path)
    try:
        text = path.read_text()
    except OSError as e:
        raise SchemaError(str(path), [f"cannot read the campaign file: {e.strerror or e}"]) from e
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as e:
        raise SchemaError(str(path), [f"not valid YAML: {e}"]) from None
    if not isinstance(doc, dict):
        raise SchemaError(str(path), ["(top level): a campaign file is a mapping (name: …)"])
    spec = resolved(parse_json(json.dumps(doc, default=str), CampaignSpec, source=str(path)),
                    path.parent)
    check_campaign(spec, source=str(path))
    return spec


def resolved(spec: CampaignSpec, folder: Path) -> CampaignSpec:
    """The spec with its submissions' relative file paths (archive, disclosure) taken
    against ``folder``, the campaign file's."""
    def beside(p: Path | None) -> Path | None:
        return (folder / p).resolve() if p is not None and not p.is_absolute() else p

    subs = tuple(s.model_copy(update={"archive": beside(s.archive),
                                      "disclosure": beside(s.disclosure)})
                 for s in spec.submissions)
    return spec.model_copy(update={"submissions": subs})


def check_campaign(spec: CampaignSpec, *, source: str) -> None:
    """What the schema alone cannot check: the track, split names, archives, disclosures
    (every problem of a named one), path lengths."""
    from plugins import PluginError, load_track

    problems: list[str] = []
    try:
        plugin = load_track(spec.track)
    except PluginError as e:
        raise SchemaError(source, [f"track: {e}"]) from None
    for i, split in enumerate(spec.splits):
        if plugin.splits and split.name not in plugin.split_names() and not split.params:
            problems.append(f"splits.{i}.name: track {spec.track!r} has no split "
                            f"{split.name!r} (it has {sorted(plugin.split_names())}); give "
                            "the split its params to define a new one")
    for i, sub in enumerate(spec.submissions):
        if sub.archive is not None and not sub.archive.is_file():
            problems.append(f"submissions.{i}.archive: no such file {sub.archive}")
        if sub.digest is not None and not sub.digest.startswith("sha256:"):
            problems.append(f"submissions.{i}.digest: an image ID is 'sha256:<64 hex>'")
        if sub.disclosure is not None:
            from orchestrator._campaign.disclosure import disclosure_problems

            problems += [f"submissions.{i}.disclosure: {sub.disclosure.name}: {p}"
                         for p in disclosure_problems(sub.disclosure)]
    if spec.runtime == "local" and spec.phase != "local":
        problems.append("runtime: 'local' runs agents without the sandbox: local phase only")
    if len(str(campaign_dir(spec))) > MAX_RUNS_DIR:
        problems.append(f"output: {campaign_dir(spec)} is longer than {MAX_RUNS_DIR} "
                        "characters, too long for the episodes' unix sockets: choose a "
                        "shorter output folder")
    if problems:
        raise SchemaError(source, problems)


def campaign_dir(spec: CampaignSpec) -> Path:
    return spec.output.resolve() / spec.name


def store_path(spec: CampaignSpec) -> Path:
    return spec.output.resolve() / "results.sqlite"


def plan(spec: CampaignSpec) -> list[Any]:
    """Every episode key, interleaved: each submission's episode i of a split is adjacent."""
    from orchestrator._results.store import EpisodeKey

    return [EpisodeKey(sub.team, split.name, i)
            for split in spec.splits for i in range(split.episodes)
            for sub in spec.submissions]


# ---------------------------------------------------------------------------- the driver
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
        import threading

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
