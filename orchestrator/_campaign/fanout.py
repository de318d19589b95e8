"""Ray fan-out: one task per episode, a progress board, and per-node label cleanup.

Each episode is one Ray task asking for ``limits.cpus`` CPUs, one GPU per granted device
and one ``eagc_slot`` (container slots a node offers: ``ray start --resources
'{"eagc_slot": 4}'``; the embedded Ray of a local campaign gets ``--workers`` of them).
Ray's own retries are off (``max_retries=0``): the driver retries infrastructure failures
itself, so that every retry is recorded and counted against ``spec.retries``.

The task creates its ``DockerRuntime`` on the node it runs on (the image is loaded there
from the submission's ``docker save`` archive if the node lacks it, then checked against
the pinned image ID), calls ``run_episode`` and returns the result as JSON with the node
it ran on. Before it starts it tells the driver's ``ProgressBoard`` actor, so the driver
knows what is running, where and in which process.
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import logging
import os
import socket
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import ray

from orchestrator._campaign.cluster import SLOT
from orchestrator._campaign.driver_io import CampaignError
from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._results.store import EpisodeKey
from schemas import CampaignSpec, EpisodeWhere, Started

log = logging.getLogger("eagc.fanout")

_PACKAGES = ("orchestrator", "plugins", "schemas", "simhost")


def code_root() -> Path:
    """The folder this installation's packages live in."""
    return Path(__file__).resolve().parents[2]


@functools.cache
def code_version(root: Path | None = None) -> str:
    """A digest of this installation's eagc sources (every .py file of the four packages).

    Driver and workers compare it: a node that runs other code (a half-done upgrade) could
    score differently, so its episodes fail as infrastructure errors instead of mixing in.
    """
    root = root or code_root()
    h = hashlib.sha256()
    for package in _PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            h.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()[:16]


@dataclass(frozen=True)
class EpisodeJob:
    """One campaign episode as its Ray task carries it: the episode itself (``spec``, built
    once by the driver) and what only a campaign adds around it. Holds the hidden seed (in
    ``spec``): it goes to the worker, never further.

    ``spec.image`` is what the submission runs (its pinned image ID, or the command of a
    local campaign); the task swaps in the ID it found on its node and the GPUs Ray gave it.
    """

    campaign: str
    submission: str
    retry: int
    spec: EpisodeSpec
    digest: str | None  # the pinned image ID (None: a local campaign's command)
    runtime: str = "docker"
    archive: list[Any] = field(default_factory=list)  # [ObjectRef of the archive bytes]
    code: str = ""  # the driver's code_version(); "" skips the check

    @property
    def episode(self) -> str:
        """The episode's id (a job's spec always names it)."""
        assert self.spec.episode is not None, "a campaign episode has an id"
        return self.spec.episode

    @property
    def key(self) -> EpisodeKey:
        """The episode's place in the campaign's plan."""
        assert self.spec.index is not None, "a campaign episode has an index"
        return EpisodeKey(self.submission, self.spec.split, self.spec.index)

    @property
    def where(self) -> EpisodeWhere:
        """The episode's place and attempt, as campaign events name it."""
        return EpisodeWhere(submission=self.submission, split=self.spec.split,
                            index=self.key.index, retry=self.retry, episode=self.episode)


def campaign_labels(campaign: str, submission: str, retry: int) -> dict[str, str]:
    """The labels a campaign puts on an episode's container (cleanup finds them by these)."""
    return {"campaign": campaign, "submission": submission, "retry": str(retry)}


@dataclass(frozen=True)
class TaskReport:
    """What a task returns: the result (JSON) or why there is none, and where it ran."""

    node: str
    host: str
    pid: int
    result_json: str | None = None
    error: str | None = None
    #: Dead episodes' containers this worker removed while it ran this task.
    reaped: int = 0


@ray.remote(num_cpus=0)
class ProgressBoard:
    """Workers report here when an episode starts; the driver drains the reports."""

    def __init__(self) -> None:
        self._events: list[Started] = []

    def started(self, event: Started) -> None:
        self._events.append(event)

    def drain(self) -> list[Started]:
        events, self._events = self._events, []
        return events


def _node() -> str:
    return ray.get_runtime_context().get_node_id()


def _ensure_image(client: Any, job: EpisodeJob) -> str:
    """The image to run on this node: the pinned ID, loaded from the archive if missing."""
    import docker

    from orchestrator._runtimes.interface import InfraError

    if job.digest is None:
        return job.spec.image

    def present() -> bool:
        try:
            client.images.get(job.digest)
            return True
        except docker.errors.ImageNotFound:
            return False

    if present():
        return job.digest
    if not job.archive:
        raise InfraError(f"image {job.digest[:19]} ({job.spec.image}) is not loaded on node "
                         f"{socket.gethostname()} and the submission has no archive")
    lock = Path(f"/tmp/eagc-image-{job.digest.split(':')[-1][:16]}.lock")
    with lock.open("w") as f:  # one load per node, however many tasks wait for it
        fcntl.flock(f, fcntl.LOCK_EX)
        if not present():
            client.images.load(ray.get(job.archive[0]))
    if not present():
        raise InfraError(f"the archive of {job.spec.image} does not hold the pinned image "
                         f"{job.digest[:19]}")
    return job.digest


def _runtime(job: EpisodeJob) -> Any:
    if job.runtime == "local":
        from orchestrator._runtimes.local import LocalProcessRuntime

        return LocalProcessRuntime(quiet=True)
    from orchestrator._runtimes.docker import DockerRuntime

    return DockerRuntime()


#: Episodes one Ray worker process runs before Ray replaces it: whatever a long-lived
#: process would accumulate per episode (the bench_soak.py run of this change found one fd
#: and an SHM segment per episode, from the host's Zenoh sessions) stays bounded. A new
#: worker costs a few seconds of imports, once per this many episodes.
EPISODES_PER_WORKER = 50


@ray.remote(max_retries=0, max_calls=EPISODES_PER_WORKER)
def episode_task(job: EpisodeJob, board: Any) -> TaskReport:
    """Runs one episode on whatever node Ray chose; never raises for agent faults."""
    from orchestrator._runtimes import reaper as _reaper

    node, host, pid = _node(), socket.gethostname(), os.getpid()
    if board is not None:
        board.started.remote(Started(**job.where.model_dump(), node=node, host=host, pid=pid))
    here = code_version()
    if job.code and job.code != here:
        return TaskReport(node, host, pid, error=(
            f"version skew: this worker runs eagc code {here} "
            f"({code_root()}), the driver {job.code}; deploy the same "
            "eagc on every node (the episode was not run)"))
    before = _reaper.reaped_here
    if job.runtime != "local":  # each worker, as it starts an episode: dead episodes' agents
        _reaper.reap_here()
    try:
        runtime = _runtime(job)
        spec = job.spec
        if job.runtime != "local":
            spec = replace(spec, image=_ensure_image(runtime.client, job))
        gpu_ids = ray.get_gpu_ids()
        if spec.limits.gpus and gpu_ids:  # the devices Ray assigned to this task
            gpus = tuple(str(g) for g in gpu_ids)
            spec = replace(spec, limits=spec.limits.model_copy(update={"gpus": gpus}))
        result = run_episode(spec, runtime)
    except Exception as e:  # noqa: BLE001 - an infrastructure failure, retried by the driver
        return TaskReport(node, host, pid, error=f"{type(e).__name__}: {e}",
                          reaped=_reaper.reaped_here - before)
    return TaskReport(node, host, pid, result_json=result.model_dump_json(),
                      reaped=_reaper.reaped_here - before)


def submit(job: EpisodeJob, board: Any) -> Any:
    """Schedules one episode task with its resources; returns its ObjectRef."""
    return episode_task.options(
        num_cpus=job.spec.limits.cpus,
        num_gpus=len(job.spec.limits.gpus),
        resources={SLOT: 1},
        name=f"eagc:{job.campaign}:{job.key}#{job.retry}",
    ).remote(job, board)


def _unmount_under(folder: str) -> list[str]:
    """Unmounts the /output tmpfs left under ``folder`` by workers that died."""
    import subprocess

    root = os.path.realpath(folder) + os.sep
    done = []
    try:
        mounts = Path("/proc/self/mounts").read_text().splitlines()
    except OSError:
        return done
    for line in mounts:
        parts = line.split()
        if len(parts) > 1 and parts[0] == "eagc-output" and parts[1].startswith(root):
            subprocess.run(["umount", "-l", parts[1]], capture_output=True)
            done.append(parts[1])
    return done


@ray.remote(num_cpus=0, max_retries=0)
def _cleanup_task(labels: dict[str, str], runs_dir: str | None) -> list[str]:
    return cleanup_here(labels, runs_dir)


def cleanup_here(labels: Mapping[str, str], runs_dir: str | None) -> list[str]:
    """Removes this node's containers with ``labels`` (and stale output mounts)."""
    from orchestrator._runtimes.docker import DockerRuntime

    removed: list[str] = []
    for _ in range(2):  # two nodes on one engine may race for the same container
        try:
            removed += DockerRuntime().cleanup(dict(labels))
            break
        except Exception:  # noqa: BLE001 - the other node removed it first
            time.sleep(0.2)
    if runs_dir is not None:
        _unmount_under(runs_dir)
    return removed


def cleanup_nodes(labels: Mapping[str, str], runs_dir: str | None,
                  timeout_s: float = 60.0) -> list[str]:
    """Runs ``cleanup_here`` on every alive node of the cluster, one after the other."""
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    removed: list[str] = []
    for node in ray.nodes():
        if not node.get("Alive"):
            continue
        strategy = NodeAffinitySchedulingStrategy(node_id=node["NodeID"], soft=False)
        ref = _cleanup_task.options(scheduling_strategy=strategy).remote(dict(labels), runs_dir)
        try:
            removed += ray.get(ref, timeout=timeout_s)
        except Exception:  # noqa: BLE001 - a node that cannot answer is reaped by `eagc cleanup`
            ray.cancel(ref, force=True)
    return removed
# ---------------------------------------------------------------------------- images
@dataclass(frozen=True)
class PinnedImage:
    team: str
    run: str  # what the runtime starts: the image ID when pinned, else the command
    digest: str | None
    archive: Path | None


def pin_images(spec: CampaignSpec, client: Any | None = None) -> dict[str, PinnedImage]:
    """Loads archives, checks pinned IDs and pins unpinned local images to their current ID."""

    if spec.runtime == "local":
        return {s.team: PinnedImage(s.team, s.image, None, None) for s in spec.submissions}
    import docker

    from orchestrator._runtimes.docker import docker_client

    client = client or docker_client()
    out = {}
    for sub in spec.submissions:
        def get(ref: str) -> Any:
            try:
                return client.images.get(ref)
            except docker.errors.ImageNotFound:
                return None

        if sub.archive is not None and (sub.digest is None or get(sub.digest) is None):
            with sub.archive.open("rb") as f:
                loaded = client.images.load(f.read())
            log.info("loaded %s from %s", [i.id for i in loaded], sub.archive)
        if sub.digest is not None:
            if get(sub.digest) is None:
                raise CampaignError(
                    f"submission {sub.team!r}: the pinned image {sub.digest} is not loaded"
                    + (" and its archive does not hold it" if sub.archive else
                       " (load its `docker save` archive, or name it in `archive:`)"))
            tagged = get(sub.image)
            if tagged is not None and tagged.id != sub.digest:
                log.warning("submission %s: %s now points to %s; running the pinned %s",
                            sub.team, sub.image, tagged.id[:19], sub.digest[:19])
            out[sub.team] = PinnedImage(sub.team, sub.digest, sub.digest, sub.archive)
            continue
        if spec.phase != "local":
            raise CampaignError(
                f"submission {sub.team!r}: a {spec.phase} campaign runs pinned images only: "
                f"add `digest: <image ID>` (docker image inspect --format '{{{{.Id}}}}' "
                f"{sub.image})")
        image = get(sub.image)
        if image is None:
            raise CampaignError(f"submission {sub.team!r}: image {sub.image!r} is not loaded "
                                "here (build it, `eagc images build`, or `docker load` it)")
        out[sub.team] = PinnedImage(sub.team, str(image.id), str(image.id), None)
    return out


