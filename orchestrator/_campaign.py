"""Campaigns: the spec from YAML, the episode plan, pinned images, and the driver (DESIGN §7).

``run_campaign(spec)`` plans every (submission, split, index), asks the results store what
is already there, and runs only the rest, one Ray task per episode, interleaving the
submissions so that they progress evenly. Results stream back with ``ray.wait`` and each is
committed at once. A result whose status is ``infra_error``, or a task whose worker died,
is recorded as an attempt and run again with a new episode id, up to ``spec.retries``
times; then the episode is quarantined (held back; the leaderboard marks that submission's
final as pending; ``--retry-quarantined`` runs it again once an organizer decided so).
Agent failures are final. Ctrl-C (or SIGTERM) cancels the running tasks, removes this
campaign's containers on every node by label and keeps everything already committed.

Files (``output`` is resolved against the working directory, archives against the
campaign file's folder)::

    <output>/results.sqlite            the results store (any number of campaigns)
    <output>/<campaign>/events.jsonl   started / committed / retry / quarantined / cancelled
    <output>/<campaign>/driver.lock    one driver per campaign
    <output>/<campaign>/ep…/           episode folders (organizer side)
"""

from __future__ import annotations

import fcntl
import json
import logging
import math
import os
import signal
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from orchestrator._errors import OrchestratorError
from schemas import CampaignSpec, EpisodeResult, SchemaError, parse_json

log = logging.getLogger("eagc.campaign")

#: ``<runs>/ep<16 hex>/sock/zenoh.sock`` must fit the 100 bytes the worker allows.
MAX_RUNS_DIR = 100 - len("/ep0123456789abcdef/sock/zenoh.sock")


class CampaignError(OrchestratorError, RuntimeError):
    """Raised when a campaign cannot start: images, the cluster, another driver, the store."""


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
    spec = parse_json(json.dumps(doc, default=str), CampaignSpec, source=str(path))
    subs = tuple(
        s.model_copy(update={"archive": (path.parent / s.archive).resolve()})
        if s.archive is not None and not s.archive.is_absolute() else s
        for s in spec.submissions
    )
    spec = spec.model_copy(update={"submissions": subs})
    check_campaign(spec, source=str(path))
    return spec


def check_campaign(spec: CampaignSpec, *, source: str) -> None:
    """What the schema alone cannot check: the track, split names, archives, path lengths."""
    from plugins import PluginError, load_track

    problems: list[str] = []
    try:
        plugin = load_track(spec.track)
    except PluginError as e:
        raise SchemaError(source, [f"track: {e}"]) from None
    for i, split in enumerate(spec.splits):
        if plugin.splits and split.name not in plugin.splits and not split.params:
            problems.append(f"splits.{i}.name: track {spec.track!r} has no split "
                            f"{split.name!r} (it has {sorted(plugin.splits)}); give the split "
                            "its params to define a new one")
    for i, sub in enumerate(spec.submissions):
        if sub.archive is not None and not sub.archive.is_file():
            problems.append(f"submissions.{i}.archive: no such file {sub.archive}")
        if sub.digest is not None and not sub.digest.startswith("sha256:"):
            problems.append(f"submissions.{i}.digest: an image ID is 'sha256:<64 hex>'")
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
    from orchestrator._store import EpisodeKey

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
    cancel_grace_s: float = 10.0


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


class Events:
    """``events.jsonl``: what the driver saw, one JSON object a line (no seeds)."""

    def __init__(self, path: Path) -> None:
        self._f: IO[str] = path.open("a")

    def write(self, kind: str, **data: Any) -> None:
        self._f.write(json.dumps({"event": kind, "at": time.time(), **data}) + "\n")
        self._f.flush()

    def close(self) -> None:
        self._f.close()


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


@contextmanager
def ray_connection(spec: CampaignSpec, options: CampaignOptions) -> Iterator[None]:
    """An existing cluster (``address``), the Ray already initialized, or an embedded one."""
    import ray

    from orchestrator._fanout import SLOT

    owned = not ray.is_initialized()
    if owned:
        quiet: dict[str, Any] = {"log_to_driver": False, "logging_level": logging.WARNING,
                                 "namespace": "eagc"}
        if options.address:
            ray.init(address=options.address, **quiet)
        else:
            cpus = max(os.cpu_count() or 1, math.ceil(options.workers * spec.limits.cpus))
            ray.init(num_cpus=cpus, resources={SLOT: float(options.workers)},
                     include_dashboard=False, **quiet)
    try:
        if not ray.cluster_resources().get(SLOT):
            raise CampaignError(f"no Ray node offers the {SLOT!r} resource: start nodes with "
                                f"`ray start … --resources '{{\"{SLOT}\": N}}'` (N containers "
                                "at a time on that node)")
        yield
    finally:
        if owned:
            ray.shutdown()


def run_campaign(spec: CampaignSpec, options: CampaignOptions | None = None, *,
                 console: Any = None) -> CampaignReport:
    """Runs what the store lacks of ``spec``; returns what this run did."""
    options = options or CampaignOptions()
    with driver_lock(campaign_dir(spec)), sigterm_as_interrupt():
        driver = Driver(spec, options, console=console)
        try:
            return driver.run()
        finally:
            driver.close()


class Driver:
    """One run of one campaign: submit, stream results, commit, retry, cancel."""

    def __init__(self, spec: CampaignSpec, options: CampaignOptions, *, console: Any) -> None:
        from rich.console import Console

        from orchestrator._metrics import CampaignMetrics
        from orchestrator._store import ResultsStore

        self.spec, self.options = spec, options
        self.name = spec.name
        self.console = console or Console(stderr=True)
        self.folder = campaign_dir(spec)
        self.store = ResultsStore(store_path(spec))
        self.events = Events(self.folder / "events.jsonl")
        self.metrics = CampaignMetrics(spec.name, track=spec.track, phase=spec.phase)
        self.report = CampaignReport(spec.name, planned=0)
        self.pending: dict[Any, Any] = {}  # ObjectRef → EpisodeJob
        self.running: dict[str, dict[str, Any]] = {}  # episode id → "started" report
        self.finished: set[str] = set()
        self.failed = 0
        self.cancelling = False
        self.seeds: dict[tuple[str, int], int] = {}
        self.pinned: dict[str, Any] = {}
        self.archives: dict[str, list[Any]] = {}
        self.board: Any = None

    def close(self) -> None:
        if self.report.metrics_port is not None and self.options.metrics_linger_s > 0:
            time.sleep(self.options.metrics_linger_s)
        self.metrics.close()
        self.store.close()
        self.events.close()

    # ------------------------------------------------------------------ run
    def run(self) -> CampaignReport:
        from orchestrator._fanout import pin_images
        from orchestrator._seeds import commitment, load_secret, seed_list

        started = time.time()
        secret = load_secret(self.spec)
        if secret.public:
            self.console.print("[yellow]seeds derive from the campaign name: they are PUBLIC "
                               "(fine for a local test, never for an official run)[/]")
        seeds = seed_list(self.spec, secret)
        self.seeds = {(s.split, s.index): s.seed for s in seeds}
        keys = plan(self.spec)
        self.report.planned = len(keys)
        self.store.register(self.spec, commitment(self.spec, seeds), len(keys))
        done = self.store.done(self.name)
        held = {q.key for q in self.store.quarantined(self.name)}
        todo = [k for k in keys if k not in done
                and (self.options.retry_quarantined or k not in held)]
        self.report.skipped = len(keys) - len(todo)
        if self.options.metrics_port is not None:
            self.report.metrics_port = self.metrics.serve(self.options.metrics_port,
                                                          self.options.metrics_addr)
        self._update_states()
        if todo:
            self.pinned = pin_images(self.spec)
            with ray_connection(self.spec, self.options):
                self._run(todo)
        self.report.wall_s = time.time() - started
        self.events.write("finished", committed=self.report.committed,
                          cancelled=self.report.cancelled, wall_s=self.report.wall_s)
        return self.report

    def _run(self, todo: list[Any]) -> None:
        import ray

        from orchestrator._fanout import ProgressBoard, cleanup_nodes

        self.board = ProgressBoard.remote()
        # Containers a killed earlier driver of this campaign left behind.
        cleanup_nodes({"campaign": self.name}, str(self.folder))
        for sub in self.spec.submissions:
            if sub.archive is not None and len(ray.nodes()) > 1:
                self.archives[sub.team] = [ray.put(sub.archive.read_bytes())]
        for key in todo:
            self._submit(key, self.store.attempts(self.name, key))
        self.events.write("submitted", episodes=len(todo))
        progress, bar = self._progress(len(todo))
        try:
            with progress:
                while self.pending:
                    self._step()
                    progress.update(bar, completed=self.report.committed + self.report.quarantined,
                                    running=len(self.running), failed=self.failed,
                                    retries=self.report.retries)
        except KeyboardInterrupt:
            self._cancel()

    def _progress(self, total: int) -> tuple[Any, Any]:
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        progress = Progress(
            TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
            TextColumn("{task.fields[running]} running · {task.fields[failed]} failed · "
                       "{task.fields[retries]} retried"),
            TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(),
            console=self.console, disable=not self.options.progress,
        )
        bar = progress.add_task(self.name, total=total, running=0, failed=0, retries=0)
        return progress, bar

    def _submit(self, key: Any, retry: int) -> None:
        from orchestrator._fanout import EpisodeJob, code_version, submit
        from orchestrator._worker import new_episode_id

        pin = self.pinned[key.submission]
        split = next(s for s in self.spec.splits if s.name == key.split)
        job = EpisodeJob(
            campaign=self.name, submission=key.submission, split=key.split, index=key.index,
            retry=retry, episode=new_episode_id(), track=self.spec.track, image=pin.run,
            digest=pin.digest, seed=self.seeds[(key.split, key.index)], params=split.params,
            limits=self.spec.limits, runs_dir=str(self.folder), runtime=self.spec.runtime,
            archive=self.archives.get(key.submission, []), code=code_version(),
        )
        self.pending[submit(job, self.board)] = job

    def _step(self) -> None:
        import ray

        refs = list(self.pending)
        ready, rest = ray.wait(refs, num_returns=1, timeout=0.5)
        if ready and rest:
            more, _ = ray.wait(rest, num_returns=len(rest), timeout=0)
            ready += more
        self._drain()
        for ref in ready:
            self._finish(ref)

    def _drain(self) -> None:
        import ray

        from orchestrator._fanout import ProgressBoard

        try:
            events = ray.get(self.board.drain.remote(), timeout=30)
        except ray.exceptions.RayError as e:  # its node died: only live progress is lost
            log.warning("the progress board is gone (%s); starting a new one", e)
            self.board = ProgressBoard.remote()
            return
        for ev in events:
            if ev["episode"] in self.finished:
                continue
            self.running[ev["episode"]] = ev
            self.events.write("started", **{k: v for k, v in ev.items() if k != "at"})
        self.metrics.set_running(len(self.running))

    # ------------------------------------------------------------------ results
    def _finish(self, ref: Any) -> None:
        import ray

        from orchestrator._fanout import cleanup_nodes
        from orchestrator._store import EpisodeKey

        job = self.pending.pop(ref)
        self.running.pop(job.episode, None)
        self.finished.add(job.episode)
        self.metrics.set_running(len(self.running))
        key = EpisodeKey(job.submission, job.split, job.index)
        where = {"submission": job.submission, "split": job.split, "index": job.index,
                 "retry": job.retry, "episode": job.episode}
        result: EpisodeResult | None = None
        node: str | None = None
        crashed = False
        try:
            report = ray.get(ref)
            node = report.node
            if report.result_json is not None:
                result = EpisodeResult.model_validate_json(report.result_json)
                message = result.failure.message if result.failure else ""
            else:
                message = report.error or "the task returned no result"
        except ray.exceptions.RayError as e:
            if self.cancelling:
                return
            crashed = True
            message = f"{type(e).__name__}: " + (str(e).strip().splitlines() or [""])[0][:300]
        if result is not None and result.status.failure_kind != "infra":
            t = time.perf_counter()
            new = self.store.commit(self.name, key, result, retry=job.retry, node=node)
            self.report.commit_s.append(time.perf_counter() - t)
            if new:
                self.report.committed += 1
                self.report.nodes.add(node or "?")
                self.failed += result.failure is not None
                self.metrics.episode_finished(job.submission, result)
            else:
                self.report.duplicates += 1
            self.events.write("committed" if new else "duplicate", **where, node=node,
                              status=result.status.value, score=result.score.total)
            self._update_states()
            return
        # An infrastructure failure: record it, then retry or quarantine.
        self.store.record_attempt(self.name, key, retry=job.retry, episode=job.episode,
                                  message=message, node=node, result=result)
        if crashed:  # the dead worker's container and output mount
            cleanup_nodes({"campaign": self.name, "episode": job.episode},
                          str(self.folder / job.episode))
        if self.cancelling:
            return
        if job.retry < self.spec.retries:
            self.report.retries += 1
            self.metrics.episode_retried(job.submission)
            self.events.write("retry", **where, node=node, message=message)
            self._submit(key, job.retry + 1)
        else:
            self.report.quarantined += 1
            self.store.quarantine(self.name, key, episode=job.episode, message=message,
                                  retries=job.retry)
            self.metrics.episode_quarantined(job.submission)
            self.events.write("quarantined", **where, node=node, message=message)
            self.console.print(f"[red]quarantined {key}[/]: {message}")
        self._update_states()

    def _update_states(self) -> None:
        c = self.store.counts(self.name)
        held, _ = c.pop("quarantined"), c.pop("retries")
        done = sum(c.values())
        planned = self.report.planned
        self.metrics.set_states({
            "planned": planned, "done": done, "failed": done - c.get("completed", 0),
            "quarantined": held, "remaining": max(0, planned - done - held),
        })

    def _cancel(self) -> None:
        import ray

        from orchestrator._fanout import cleanup_nodes

        self.cancelling = True
        self.report.cancelled = True
        self.console.print(f"[yellow]cancelling {len(self.pending)} episode(s); committed "
                           "results are kept, run the campaign again to resume[/]")
        self.events.write("cancelled", pending=len(self.pending))
        for ref in self.pending:
            ray.cancel(ref)  # KeyboardInterrupt in the task: run_episode stops its container
        deadline = time.time() + self.options.cancel_grace_s
        try:
            while self.pending and time.time() < deadline:
                ready, _ = ray.wait(list(self.pending), num_returns=len(self.pending),
                                    timeout=0.5)
                for ref in ready:
                    self._finish(ref)
        except KeyboardInterrupt:
            pass
        for ref in self.pending:
            ray.cancel(ref, force=True)
        self.pending.clear()
        cleanup_nodes({"campaign": self.name}, str(self.folder))
