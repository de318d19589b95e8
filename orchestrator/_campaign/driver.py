"""The campaign driver: submit, stream results, commit, retry, cancel, fail cleanly.

``run_campaign(spec)`` takes the campaign's driver lock and runs a ``Driver``: it plans
every (submission, split, index), asks the results store what is already there, and runs
only the rest, one Ray task per episode, interleaving the submissions so that they progress
evenly. Results stream back with ``ray.wait`` and each is committed at once. A result whose
status is ``infra_error``, or a task whose worker died, is recorded as an attempt and run
again with a new episode id, up to ``spec.retries`` times; then the episode is quarantined
(held back; the leaderboard marks that submission's final as pending;
``--retry-quarantined`` runs it again once an organizer decided so). Agent failures are
final. Its options, report, exit codes and files are ``orchestrator._campaign.driver_io``;
the Ray cluster and its watch, ``orchestrator._campaign.cluster``.

What it guarantees under faults (docs/operations.md, "Faults"):

* every result is committed once, at once, before anything else is done with it;
* Ctrl-C / SIGTERM: the running tasks are cancelled, the campaign's containers removed on
  every node and output mounts released; exit 130;
* the store fails (a full disk, an I/O error) or the Ray cluster is lost: the same cancel
  path (for a lost cluster, on this node through the engine directly, the other nodes'
  containers being bounded by their episode watchers), one message, exit 5 or 6; nothing
  committed is lost and ``eagc campaign rebuild-store`` adds what finished meanwhile. A
  lost cluster is noticed within seconds (``ClusterWatch``: this node's raylet within about
  a second, the GCS within ``cluster_patience_s``), before Ray's own 60 s abort, which
  would skip all of this, even when a Ray call of the driver's waits for the dead GCS;
* a store that is damaged, or holds fewer results than ``events.jsonl`` says were
  committed (an empty file put in its place), is refused before anything runs;
* an in-flight episode is charged a retry only when its own node failed.

The progress board (which episodes run where) is an actor pinned to the driver's own node,
so that the loss of a worker node never takes live progress with it.
"""

from __future__ import annotations

import logging
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from orchestrator._campaign.cluster import ClusterLost, ClusterWatch, ray_connection
from orchestrator._campaign.disclosure import keep_disclosures
from orchestrator._campaign.driver_io import (
    EXIT_CLUSTER,
    EXIT_STORE,
    CampaignOptions,
    CampaignReport,
    DriverFailure,
    Events,
    driver_lock,
    sigterm_as_interrupt,
)
from orchestrator._campaign.spec import campaign_dir, plan, store_path
from orchestrator._results.store import REBUILD, EpisodeKey, StoreDamaged, StoreError
from schemas import (
    CampaignSpec,
    Committed,
    EpisodeResult,
    Finished,
    Retried,
    Started,
    Stopped,
    Submitted,
)

if TYPE_CHECKING:
    from orchestrator._campaign.fanout import EpisodeJob

log = logging.getLogger("eagc.campaign")


def private_folder(path: Path) -> Path:
    """Creates ``path`` (and parents) and makes it 0700: it holds hidden scenarios."""
    path.mkdir(parents=True, exist_ok=True)
    try:
        path.chmod(0o700)
    except PermissionError:  # someone else's folder: say so, never fail a campaign for it
        log.warning("cannot make %s private (0700): it is not ours", path)
    return path


def run_campaign(spec: CampaignSpec, options: CampaignOptions | None = None, *,
                 console: Any = None) -> CampaignReport:
    """Runs what the store lacks of ``spec``; returns what this run did."""
    options = options or CampaignOptions()
    private_folder(spec.output.resolve())
    with driver_lock(campaign_dir(spec)), sigterm_as_interrupt():
        driver = Driver(spec, options, console=console)
        try:
            return driver.run()
        finally:
            driver.close()


def check_store_against_events(store: Any, folder: Path, campaign: str) -> None:
    """StoreDamaged if ``events.jsonl`` names committed episodes the store lacks."""
    from orchestrator._campaign.rebuild import committed_episodes, read_events

    named = committed_episodes(read_events(folder / "events.jsonl"))
    if not named:
        return
    missing = named - store.episode_ids(campaign)
    if missing:
        raise StoreDamaged(
            f"the results store {store.path} lacks {len(missing)} of the {len(named)} "
            f"results that {folder / 'events.jsonl'} says were committed (an empty, replaced "
            f"or damaged store). Running on would run them again: rebuild it first with "
            f"{REBUILD}")


class Driver:
    """One run of one campaign: submit, stream results, commit, retry, cancel."""

    def __init__(self, spec: CampaignSpec, options: CampaignOptions, *, console: Any) -> None:
        from rich.console import Console

        from orchestrator._campaign.metrics import CampaignMetrics
        from orchestrator._results.store import ResultsStore

        self.spec, self.options = spec, options
        self.name = spec.name
        self.console = console or Console(stderr=True)
        self.folder = private_folder(campaign_dir(spec))
        self.metrics = CampaignMetrics(spec.name, track=spec.track, phase=spec.phase)
        self.metrics.start_series(spec)
        self.store = ResultsStore(store_path(spec))
        self.events = Events(self.folder / "events.jsonl")
        self.report = CampaignReport(spec.name, planned=0)
        self.pending: dict[Any, EpisodeJob] = {}  # ObjectRef → its job
        self.running: dict[str, Started] = {}  # episode id → its worker's "started" report
        self.finished: set[str] = set()
        self.failed = 0
        self.cancelling = False
        self.broken: BaseException | None = None  # the store or cluster fault that stops us
        self.seeds: dict[tuple[str, int], int] = {}
        self.pinned: dict[str, Any] = {}
        self.archives: dict[str, list[Any]] = {}
        self.board: Any = None
        self.watch: ClusterWatch | None = None
        self.here = ""  # the driver's own Ray node
        self._nodes_checked = 0.0

    def close(self) -> None:
        if self.watch is not None:
            self.watch.close()
        if self.report.metrics_port is not None and self.options.metrics_linger_s > 0:
            time.sleep(self.options.metrics_linger_s)
        self.metrics.close()
        self.store.close()
        self.events.close()

    # ------------------------------------------------------------------ run
    def run(self) -> CampaignReport:
        from orchestrator._campaign.fanout import pin_images
        from orchestrator._campaign.seeds import commitment, load_secret, seed_list

        started = time.time()
        secret = load_secret(self.spec)
        if secret.public:
            self.console.print("[yellow]seeds derive from the campaign name: they are PUBLIC "
                               "(fine for a local test, never for an official run)[/]")
        seeds = seed_list(self.spec, secret)
        self.seeds = {(s.split, s.index): s.seed for s in seeds}
        keys = plan(self.spec)
        self.report.planned = len(keys)
        self.store.check()
        check_store_against_events(self.store, self.folder, self.name)
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
            keep_disclosures(self.spec, self.pinned, self.folder)
            with ray_connection(self.spec, self.options):
                self._run(todo)
        self.report.wall_s = time.time() - started
        self.events.write(Finished(committed=self.report.committed,
                                   cancelled=self.report.cancelled, wall_s=self.report.wall_s))
        return self.report

    def _run(self, todo: list[Any]) -> None:
        import ray
        from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

        from orchestrator._campaign.fanout import ProgressBoard, cleanup_nodes

        here = self.here = ray.get_runtime_context().get_node_id()
        raylet = next(((n["NodeManagerAddress"], int(n["NodeManagerPort"]))
                       for n in ray.nodes() if n["NodeID"] == here), None)
        self.watch = ClusterWatch(ray.get_runtime_context().gcs_address,
                                  self.options.cluster_patience_s, raylet=raylet,
                                  on_stuck=self._stuck)
        try:
            self.board = ProgressBoard.options(
                scheduling_strategy=NodeAffinitySchedulingStrategy(node_id=here, soft=False)
            ).remote()
            # Containers a killed earlier driver of this campaign left behind.
            self._reaped(len(self.watch.call(cleanup_nodes, {"campaign": self.name},
                                             str(self.folder))))
            for sub in self.spec.submissions:
                if sub.archive is not None and len(ray.nodes()) > 1:
                    self.archives[sub.team] = [ray.put(sub.archive.read_bytes())]
            for key in todo:
                self._submit(key, self.store.attempts(self.name, key))
            self.events.write(Submitted(episodes=len(todo), board_node=here))
            progress, bar = self._progress(len(todo))
            with progress:
                while self.pending:
                    self._step()
                    progress.update(bar, completed=self.report.committed + self.report.quarantined,
                                    running=len(self.running), failed=self.failed,
                                    retries=self.report.retries)
                self._drain()  # "started" reports the board got after the last result
        except KeyboardInterrupt:
            self._cancel()
        except (StoreError, ClusterLost) as e:
            self._fail(e)

    def _progress(self, total: int) -> tuple[Any, Any]:
        """A progress bar on a terminal that fits its width (the times never cut); one plain
        line per finished episode where the console is not a terminal (a pipe, a file)."""
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            ProgressColumn,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )
        from rich.table import Column
        from rich.text import Text

        if not self.console.is_terminal:
            plain = _PlainProgress(self.console, self.name, total, self.options.progress)
            return plain, None

        class Counts(ProgressColumn):
            """'2 running', then the failed and retried ones where there are any."""

            def render(self, task: Any) -> Text:
                f = task.fields
                parts = [f"{f['running']} running"]
                parts += [f"{f['failed']} failed"] if f["failed"] else []
                parts += [f"{f['retries']} retried"] if f["retries"] else []
                return Text(" · ".join(parts))

        def whole() -> Column:
            return Column(no_wrap=True, overflow="ignore")

        progress = Progress(
            TextColumn("[bold]{task.description}",
                       table_column=Column(no_wrap=True, overflow="ellipsis", max_width=18)),
            BarColumn(bar_width=None, table_column=Column(ratio=1)),
            MofNCompleteColumn(table_column=whole()), Counts(table_column=whole()),
            TimeElapsedColumn(table_column=whole()), TextColumn("ETA", table_column=whole()),
            TimeRemainingColumn(table_column=whole()),
            console=self.console, disable=not self.options.progress,
        )
        bar = progress.add_task(self.name, total=total, running=0, failed=0, retries=0)
        return progress, bar

    def _submit(self, key: EpisodeKey, retry: int) -> None:
        from orchestrator._campaign.fanout import EpisodeJob, campaign_labels, code_version, submit
        from orchestrator._episode.worker import EpisodeSpec, new_episode_id

        pin = self.pinned[key.submission]
        split = next(s for s in self.spec.splits if s.name == key.split)
        episode = EpisodeSpec(
            track=self.spec.track, image=pin.run, seed=self.seeds[(key.split, key.index)],
            split=key.split, params=dict(split.params), limits=self.spec.limits,
            runs_dir=self.folder, labels=campaign_labels(self.name, key.submission, retry),
            episode=new_episode_id(), index=key.index)
        job = EpisodeJob(campaign=self.name, submission=key.submission, retry=retry,
                         spec=episode, digest=pin.digest, runtime=self.spec.runtime,
                         archive=self.archives.get(key.submission, []), code=code_version())
        self.pending[submit(job, self.board)] = job

    def _check_cluster(self) -> None:
        """ClusterLost once the watch saw the cluster go (``ClusterWatch.check``)."""
        if self.watch is not None:
            self.watch.check()

    def _step(self) -> None:
        import ray

        self._check_cluster()
        refs = list(self.pending)
        ready, rest = ray.wait(refs, num_returns=1, timeout=0.5)
        if ready and rest:
            more, _ = ray.wait(rest, num_returns=len(rest), timeout=0)
            ready += more
        self._drain()
        for ref in ready:
            self._finish(ref)
        self._check_nodes()

    def _check_nodes(self, every_s: float = 5.0) -> None:
        """Episodes whose node Ray declared dead are retried now: the task's own failure may
        reach the driver only minutes later (a node cut off the network answers nothing, and
        Ray waits for its gRPC keepalive)."""
        import ray

        if time.monotonic() - self._nodes_checked < every_s:
            return
        self._nodes_checked = time.monotonic()
        try:
            nodes = self.watch.call(ray.nodes, timeout_s=10.0)
        except ClusterLost:
            raise
        except Exception as e:  # noqa: BLE001 - the GCS is busy: ask again later
            log.warning("could not list Ray's nodes: %s", e)
            return
        dead = {n["NodeID"] for n in nodes if not n.get("Alive")}
        if not dead:
            return
        for ref, job in list(self.pending.items()):
            started = self.running.get(job.episode)
            node = None if started is None else started.node
            if node not in dead:
                continue
            self.pending.pop(ref)
            self.running.pop(job.episode, None)
            self.finished.add(job.episode)
            self.metrics.set_running(len(self.running))
            ray.cancel(ref, force=True)
            message = f"NodeDiedError: the node running the episode ({node[:12]}) was lost"
            try:
                # No cleanup through Ray: the node cannot be reached. Its containers lose
                # their heartbeat with its workers and are reaped (orchestrator._runtimes.reaper).
                self._record(job, None, node, True, message, reach=False)
            except StoreError:
                self.metrics.store_error()
                raise

    def _drain(self) -> None:
        import ray

        from orchestrator._campaign.fanout import ProgressBoard

        try:
            events = self.watch.get(self.board.drain.remote(), timeout_s=10)
        except ray.exceptions.RayError as e:  # the driver's own node is in trouble
            self._check_cluster()
            log.warning("the progress board is gone (%s); starting a new one", e)
            self.board = ProgressBoard.remote()
            return
        for ev in events:
            if ev.episode not in self.finished:  # one that already finished is not running,
                self.running[ev.episode] = ev  # but the log keeps where it started
            self.events.write(ev.model_copy(update={"at": time.time()}))
        self.metrics.set_running(len(self.running))

    def _reaped(self, n: int) -> None:
        if n:
            self.report.reaped += n
            self.metrics.containers_reaped(n)

    # ------------------------------------------------------------------ results
    def _finish(self, ref: Any) -> None:
        import ray

        job = self.pending.pop(ref)
        started = self.running.pop(job.episode, None)
        self.finished.add(job.episode)
        self.metrics.set_running(len(self.running))
        if self.broken is not None:  # the result stays in its folder: rebuild-store finds it
            return
        result: EpisodeResult | None = None
        node: str | None = None
        crashed = False
        try:
            report = ray.get(ref)
            node = report.node
            self._reaped(report.reaped)
            if report.result_json is not None:
                result = EpisodeResult.model_validate_json(report.result_json)
                message = result.failure.message if result.failure else ""
            else:
                message = report.error or "the task returned no result"
        except ray.exceptions.RayError as e:
            if self.cancelling:
                return
            # Charged only if the fault was on the episode's own node: with the whole
            # cluster gone, or this driver's own raylet, nobody's episode is to blame.
            self._blame(e, None if started is None else started.node)
            crashed = True
            message = f"{type(e).__name__}: " + (str(e).strip().splitlines() or [""])[0][:300]
        try:
            self._record(job, result, node, crashed, message)
        except StoreError:
            self.metrics.store_error()
            raise

    def _blame(self, error: Exception, node: str | None) -> None:
        """ClusterLost unless the failed task's own node is to blame: Ray says this node's
        raylet died under it, or the GCS or this node's raylet stops answering now or a
        second later (a cluster being killed ends its workers before its GCS)."""
        import ray

        if self.watch is None:
            return
        if isinstance(error, ray.exceptions.LocalRayletDiedError) and node == self.here:
            self.watch.mark_lost("this node's raylet died")
        elif self.watch.confirm():
            return
        self._check_cluster()

    def _record(self, job: EpisodeJob, result: EpisodeResult | None, node: str | None,
                crashed: bool, message: str, *, reach: bool = True) -> None:
        from orchestrator._campaign.fanout import cleanup_nodes

        key, where = job.key, job.where
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
            self.events.write(Committed(**where.model_dump(), node=node,
                                        event="committed" if new else "duplicate",
                                        status=result.status.value, score=result.score.total))
            self._update_states()
            return
        # An infrastructure failure: record it, then retry or quarantine.
        self.store.record_attempt(self.name, key, retry=job.retry, episode=job.episode,
                                  message=message, node=node, result=result)
        if crashed and reach:  # the dead worker's container and output mount
            self._reaped(len(self.watch.call(
                cleanup_nodes, {"campaign": self.name, "episode": job.episode},
                str(self.folder / job.episode))))
        if self.cancelling:
            return
        if job.retry < self.spec.retries:
            self.report.retries += 1
            self.metrics.episode_retried(job.submission)
            self.events.write(Retried(**where.model_dump(), node=node, message=message))
            self._submit(key, job.retry + 1)
        else:
            self.report.quarantined += 1
            self.store.quarantine(self.name, key, episode=job.episode, message=message,
                                  retries=job.retry)
            self.metrics.episode_quarantined(job.submission)
            self.events.write(Retried(**where.model_dump(), node=node, message=message,
                                      event="quarantined"))
            self.console.print(f"[red]quarantined {key}[/]: {message}")
        self._update_states()

    def _update_states(self) -> None:
        c = self.store.counts(self.name)
        planned = self.report.planned
        self.metrics.set_states({
            "planned": planned, "done": c.done, "failed": c.done - c.completed,
            "quarantined": c.quarantined,
            "remaining": max(0, planned - c.done - c.quarantined),
        })

    # ------------------------------------------------------------------ endings
    def _cancel(self) -> None:
        import ray

        from orchestrator._campaign.fanout import cleanup_nodes

        self.cancelling = True
        self.report.cancelled = True
        if self.broken is None:
            self.console.print(f"[yellow]cancelling {len(self.pending)} episode(s); committed "
                               "results are kept, run the campaign again to resume[/]")
        self.events.try_write(Stopped(pending=len(self.pending)))
        # Ray's cancel races with a task's own reply (its core worker then aborts the whole
        # process: "Tried to complete task that was not pending"): cancel only tasks not
        # known to be done, once each, and never force-kill one that may be finishing. A
        # task still running after the grace is ended by the container cleanup below (its
        # agent is gone) and by Ray when this driver leaves.
        deadline = time.time() + self.options.cancel_grace_s
        try:
            self._collect(timeout=0)
            for ref in self.pending:
                ray.cancel(ref)  # KeyboardInterrupt in the task: run_episode stops its container
            while self.pending and time.time() < deadline:
                self._collect(timeout=0.5)
        except KeyboardInterrupt:
            pass
        self.pending.clear()
        try:
            self._reaped(len(self.watch.call(cleanup_nodes, {"campaign": self.name},
                                             str(self.folder))))
        except ClusterLost:  # lost while cancelling: this node's containers, without Ray
            self._cleanup_here()

    def _collect(self, timeout: float) -> None:
        """Finish (commit) whichever pending tasks are done within ``timeout`` seconds."""
        import ray

        if not self.pending:
            return
        ready, _ = ray.wait(list(self.pending), num_returns=len(self.pending),
                            timeout=timeout)
        for ref in ready:
            try:
                self._finish(ref)
            except StoreError as e:  # the store broke while we were cancelling
                self.broken = self.broken or e

    def _fail(self, fault: StoreError | ClusterLost) -> None:
        """The store or the cluster failed: the cancel path, then DriverFailure."""
        self.broken = fault
        lost = isinstance(fault, ClusterLost)
        self.events.try_write(Stopped(event="failed", reason="cluster" if lost else "store",
                                      message=str(fault), pending=len(self.pending)))
        if lost:
            # No Ray to ask: this node's containers through the engine; other nodes' are
            # bounded by their episode watchers (no heartbeat: removed within a minute).
            self.report.cancelled = True
            self._cleanup_here()
            self.pending.clear()
        else:
            self._cancel()
        raise DriverFailure(self._failure_message(fault),
                            EXIT_CLUSTER if lost else EXIT_STORE) from None

    def _failure_message(self, fault: StoreError | ClusterLost) -> str:
        kept = self.report.committed + self.report.skipped
        return (f"{fault}. The campaign stopped: running episodes were cancelled and their "
                f"containers removed; the {kept} result(s) committed are kept. "
                + ("Start the Ray cluster again, then run the campaign again: it resumes."
                   if isinstance(fault, ClusterLost) else
                   f"Then run the campaign again (it resumes); `{REBUILD}` adds results that "
                   "finished after the failure."))

    def _cleanup_here(self) -> None:
        """This node's containers of the campaign, through the engine (no Ray)."""
        from orchestrator._campaign.fanout import cleanup_here

        try:
            self._reaped(len(cleanup_here({"campaign": self.name}, str(self.folder))))
        except Exception as e:  # noqa: BLE001 - no engine here: the watchers remain
            log.warning("local cleanup after losing the cluster: %s", e)

    def _stuck(self) -> None:
        """The watch's last resort, on its own thread: the cluster is lost and the driver's
        thread did not notice within the watch's grace, waiting in a Ray call that Ray ends
        only with its 60 s abort (no cleanup). The same ending as ``_fail`` for a lost
        cluster, without Ray and without the driver's thread: the event, this node's
        containers, one line on stderr, exit 6 (``os._exit``: Ray's exit hooks would wait
        for the dead GCS too). Committed results are in the store already."""
        fault = self.watch.error()
        message = str(fault)
        try:
            self.events.try_write(Stopped(event="failed", reason="cluster", message=message,
                                          pending=len(self.pending)))
            self._cleanup_here()
            message = self._failure_message(fault)
        except BaseException as e:  # noqa: BLE001 - the process ends below whatever happens
            log.warning("ending the campaign without Ray: %s", e)
        finally:
            print(f"error: {message}", file=sys.stderr, flush=True)
            os._exit(EXIT_CLUSTER)


class _PlainProgress:
    """The progress of a campaign where nobody watches a terminal: one line per finished
    episode (``<campaign>: 3/10 episodes done · 1 failed · 0 retried · 0:01:05``), printed
    as it happens; the same calls as rich's Progress."""

    def __init__(self, console: Any, name: str, total: int, show: bool) -> None:
        import time

        self.console, self.name, self.total, self.show = console, name, total, show
        self.done = 0
        self.start = time.monotonic()

    def __enter__(self) -> _PlainProgress:
        return self

    def __exit__(self, *exc: Any) -> None:
        return None

    def update(self, _bar: Any, *, completed: int, failed: int = 0, retries: int = 0,
               **_: Any) -> None:
        import time

        while self.show and self.done < completed:
            self.done += 1
            took = int(time.monotonic() - self.start)
            self.console.print(
                f"{self.name}: {self.done}/{self.total} episodes done · {failed} failed · "
                f"{retries} retried · {took // 3600}:{took // 60 % 60:02d}:{took % 60:02d}",
                highlight=False, markup=False, soft_wrap=True)

