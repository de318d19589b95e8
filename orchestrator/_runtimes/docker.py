"""``DockerRuntime``: the sandbox (docs/architecture.md, 'The sandbox'), through the docker SDK.

No network; read-only root; uid 10001; all capabilities dropped; no-new-privileges; default
seccomp; pids, memory (swap = memory) and CPU limits; a size-capped /tmp tmpfs; /output a
bind-mounted host folder (size-capped by the worker); the socket folder and inputs read-only;
GPUs only by device id; a capped log; labels so that orphans can be found.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from orchestrator._runtimes.engine import docker_client, managed_containers
from orchestrator._runtimes.interface import (
    LABEL_PREFIX,
    AgentHandle,
    AgentLaunch,
    AgentRuntime,
    AgentStartError,
    InfraError,
    sample_interval,
)
from orchestrator._runtimes.reaper import HEARTBEAT_LABEL, start_watcher
from schemas import CONTAINER, ContainerExit

log = logging.getLogger("eagc.docker")

_CGROUP_PEAK = (
    "/sys/fs/cgroup/memory/docker/{id}/memory.max_usage_in_bytes",  # v1, cgroupfs driver
    "/sys/fs/cgroup/memory/system.slice/docker-{id}.scope/memory.max_usage_in_bytes",
    "/sys/fs/cgroup/system.slice/docker-{id}.scope/memory.peak",  # v2, systemd driver
    "/sys/fs/cgroup/docker/{id}/memory.peak",  # v2, cgroupfs driver
)


def read_peak_memory(container_id: str) -> int | None:
    """Peak memory of a container from its cgroup (readable until the container is removed)."""
    for pattern in _CGROUP_PEAK:
        try:
            return int(Path(pattern.format(id=container_id)).read_text().strip())
        except (OSError, ValueError):
            continue
    return None


class DockerAgent(AgentHandle):
    def __init__(self, container: Any, memory_limit: int) -> None:
        self.container = container
        self.id = container.id
        self._exit: ContainerExit | None = None
        self._lock = threading.Lock()
        self._limit = memory_limit
        # The cgroup goes when the container exits (seen on cgroup v1 here), so its peak is
        # sampled while it runs and read once more just before the host kills it.
        self.peak: int | None = None
        self._done = threading.Event()
        threading.Thread(target=self._sample, daemon=True, name=f"peak-{self.id[:12]}").start()

    def _sample(self) -> None:
        # The cgroup's figure is a high-water mark: one read while the container runs is enough.
        started = time.monotonic()
        while True:
            self.checkpoint()
            if self._done.wait(sample_interval(time.monotonic() - started)):
                return

    def checkpoint(self) -> None:
        value = read_peak_memory(self.id)
        if value is not None:
            self.peak = max(self.peak or 0, value)

    def wait(self, timeout: float | None) -> bool:
        import requests

        try:
            self.container.wait(timeout=timeout)
            return True
        except (requests.exceptions.ReadTimeout, requests.exceptions.ConnectionError):
            return False
        except Exception:  # noqa: BLE001 - a removed container has exited
            return True

    def stop(self) -> ContainerExit:
        import docker

        with self._lock:
            if self._exit is not None:
                return self._exit
            c = self.container
            killed = False
            try:
                try:
                    c.reload()
                except docker.errors.NotFound:
                    # Removed under us (the orphan reaper, an operator): how it ended is gone
                    # with it. It did not end by itself while the episode watched.
                    self._exit = ContainerExit(
                        exit_code=None, killed_by_host=True, peak_memory_bytes=self.peak,
                        log_tail="(the container was removed before its exit could be read)",
                    )
                    return self._exit
                if c.attrs["State"]["Running"]:
                    self.checkpoint()
                    try:
                        c.kill()
                        killed = True
                    except docker.errors.APIError as e:  # it exited since the reload
                        if e.status_code != 409:
                            raise
                c.wait(timeout=30)
                c.reload()
                state = c.attrs["State"]
                self._done.set()
                peak = self.peak
                if state.get("OOMKilled"):
                    peak = max(peak or 0, self._limit)  # it reached the limit, by definition
                tail = c.logs(tail=40).decode("utf-8", errors="replace")
                self._exit = ContainerExit(
                    exit_code=state.get("ExitCode"),
                    oom_killed=bool(state.get("OOMKilled")),
                    killed_by_host=killed,
                    exited_early=False,
                    peak_memory_bytes=peak,
                    log_tail=tail[-4000:],
                )
            finally:
                self._done.set()
                try:
                    c.remove(force=True)
                except Exception as e:  # noqa: BLE001 - reported, the reaper gets it later
                    log.warning("could not remove container %s: %s", c.id[:12], e)
            return self._exit


class DockerRuntime(AgentRuntime):
    """Runs each agent in a locked-down container."""

    name = "docker"
    official = True

    def __init__(self, client: Any | None = None, *, cpuset: str | None = None) -> None:
        self.client = client or docker_client()
        self.cpuset = cpuset

    def container_options(self, launch: AgentLaunch) -> dict[str, Any]:
        """The engine's options for ``launch``'s container (``containers.create``/``run``
        keyword arguments, the image aside): the sandbox, the limits, the mounts, and a
        device request for the GPUs in ``launch.limits.gpus``."""
        import docker

        lim = launch.limits
        volumes = {
            str(launch.socket_dir): {"bind": CONTAINER.socket_dir, "mode": "ro"},
            str(launch.output_dir): {"bind": CONTAINER.output_dir, "mode": "rw"},
        }
        if launch.input_dir is not None:
            volumes[str(launch.input_dir)] = {"bind": CONTAINER.input_dir, "mode": "ro"}
        env = launch.environment(
            socket_dir=CONTAINER.socket_dir,
            output_dir=CONTAINER.output_dir,
            input_dir=CONTAINER.input_dir if launch.input_dir is not None else None,
        )
        labels = {f"{LABEL_PREFIX}.managed": "true", f"{LABEL_PREFIX}.episode": launch.episode}
        labels.update({f"{LABEL_PREFIX}.{k}": str(v) for k, v in launch.labels.items()})
        if launch.heartbeat is not None:
            labels[HEARTBEAT_LABEL] = str(launch.heartbeat)
        device_requests = []
        if lim.gpus:
            device_requests.append(
                docker.types.DeviceRequest(device_ids=list(lim.gpus), capabilities=[["gpu"]])
            )
        return dict(
            name=f"eagc-{launch.episode}",
            network_mode="none",
            read_only=True,
            user=f"{CONTAINER.uid}:{CONTAINER.uid}",
            cap_drop=["ALL"],
            security_opt=["no-new-privileges"],
            pids_limit=lim.pids,
            mem_limit=f"{lim.memory_mb}m",
            memswap_limit=f"{lim.memory_mb}m",
            nano_cpus=int(lim.cpus * 1e9),
            cpuset_cpus=launch.cpuset or self.cpuset,
            tmpfs={"/tmp": f"rw,nosuid,nodev,size={lim.tmp_mb}m,mode=1777"},
            volumes=volumes,
            environment=env,
            labels=labels,
            log_config=docker.types.LogConfig(
                type="json-file", config={"max-size": f"{lim.log_mb}m", "max-file": "1"}
            ),
            device_requests=device_requests or None,
            ipc_mode="private",
            stdin_open=False,
            tty=False,
        )

    def start(self, launch: AgentLaunch) -> AgentHandle:
        import docker

        lim = launch.limits
        try:
            # Never pull: images reach nodes as `docker save` archives, and no registry is
            # reachable anyway. A missing image is the submission's fault.
            self.client.images.get(launch.image)
        except docker.errors.ImageNotFound as e:
            raise AgentStartError(f"image {launch.image!r} is not loaded on this node") from e
        except docker.errors.APIError as e:
            raise InfraError(f"engine error looking up {launch.image!r}: {e}") from e
        try:
            container = self.client.containers.run(
                launch.image, detach=True, **self.container_options(launch))
        except docker.errors.ImageNotFound as e:
            raise AgentStartError(f"image {launch.image!r} not found on this node") from e
        except docker.errors.APIError as e:
            if e.status_code is not None and 400 <= e.status_code < 500:
                raise AgentStartError(f"the engine refused to start {launch.image!r}: {e}") from e
            raise InfraError(f"engine error starting {launch.image!r}: {e}") from e
        except Exception as e:  # noqa: BLE001
            raise InfraError(f"engine error starting {launch.image!r}: {e}") from e
        if launch.heartbeat is not None and launch.deadline_s is not None:
            # From outside the container and outside Ray: ends it at the deadline, or as
            # soon as no worker keeps its heartbeat (the worker, the node or Ray died).
            try:
                start_watcher(container.id, launch.heartbeat, time.time() + launch.deadline_s)
            except Exception as e:  # noqa: BLE001 - the reapers still bound it
                log.warning("no episode watcher for %s: %s", container.name, e)
        return DockerAgent(container, lim.memory_mb << 20)

    def cleanup(self, labels: Mapping[str, str] | None = None) -> list[str]:
        filters = [f"{LABEL_PREFIX}.managed=true"]
        filters += [f"{LABEL_PREFIX}.{k}={v}" for k, v in (labels or {}).items()]
        from docker.errors import NotFound

        removed = []
        for c in managed_containers(self.client, filters):
            try:
                c.remove(force=True)
            except NotFound:  # removed by a watcher or reaper meanwhile
                continue
            removed.append(c.name)
        return removed
