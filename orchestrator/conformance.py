"""The conformance suites every container runtime must pass (like dm_env_rpc's
``compliance/``), and the one a track's hooks must pass on real episodes.

Subclass it in a test module and give it two pytest fixtures: ``runtime`` (the
``AgentRuntime`` under test) and ``probe_image`` (what that runtime starts to run the probe
agent, ``orchestrator/_programs/runtime_probe.py``)::

    from orchestrator.conformance import RuntimeConformance, SandboxConformance

    class TestMyRuntime(SandboxConformance):      # an official runtime: the whole sandbox
        @pytest.fixture
        def runtime(self): return MyRuntime()

        @pytest.fixture
        def probe_image(self): return "eagc-test/runtime-probe:latest"

The probe reads its orders from the input folder and writes its findings to the output
folder, so one probe image serves every test, and the checks see the runtime from inside.

``RuntimeConformance`` is what every runtime owes the episode worker: the exit code and the
agent's last log lines come back; a hanging agent is killed on ``stop()``, which is
idempotent; the agent's environment is the container contract; its children die with it; a
runaway allocation ends the agent; a missing image is the agent's fault (``AgentStartError``).
``SandboxConformance`` adds the sandbox for official runtimes (docs/architecture.md, 'The
sandbox'), checked from inside: non-root, no capabilities, no-new-privileges, seccomp;
read-only root and input, capped ``/tmp``; no network; nothing of the host's environment; a
pids limit that holds a fork bomb; an OOM kill reported as such; detached daemons gone with
the agent; ``cleanup`` finds leftovers by label.

The probe's findings (``probe-result.json``) are read as ``ProbeFindings``: the probe is a
standard-library program, its report is ours, and a check reads it by attribute.

``probe_build_context(folder)`` writes a Docker build context for the probe image.

``TrackEpisodeConformance`` is what the orchestrator asks of a track plugin beyond
``plugins.conformance.TrackConformance``: a short local campaign of the track (one episode
per team, the agent a plain process) is played through the episode worker, then its
leaderboard, its pages (``eagc report``: the track's map, pictures and truth), each
episode's audit (the replay and the track's checks) and the track's section of the
protocol page are made from it. Subclass it and set ``track`` and ``agent`` (a command that
plays an episode of the track)::

    class TestMyTrackEpisodes(TrackEpisodeConformance):
        track = "my_track"
        agent = "python examples/my_agent/agent.py"

Requires pytest only to run.
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import tempfile
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict, Field

from orchestrator._episode.collect import mount_output, unmount_output
from orchestrator._runtimes.interface import (
    AgentHandle,
    AgentLaunch,
    AgentRuntime,
    AgentStartError,
)
from schemas import CONTAINER, ContainerExit, Limits, unix_endpoint

__all__ = [
    "PROBE_SCRIPT",
    "TrackEpisodeConformance",
    "FilesystemFindings",
    "ProbeFindings",
    "ProbeReport",
    "ProbeRun",
    "RuntimeConformance",
    "SandboxConformance",
    "probe_build_context",
]

#: The probe agent's script (standard library only).
PROBE_SCRIPT = Path(__file__).parent / "_programs" / "runtime_probe.py"
_RESULT = "probe-result.json"
#: Environment variables a sandboxed agent may see besides the contract's: what a base image
#: sets for itself (and ``LC_*``).
_IMAGE_ENV = {"PATH", "HOSTNAME", "HOME", "LANG", "TERM", "PYTHONUNBUFFERED",
              "PYTHONDONTWRITEBYTECODE", "PYTHONPATH", "VIRTUAL_ENV", "container"}


class _Found(BaseModel):
    model_config = ConfigDict(frozen=True, extra="ignore", populate_by_name=True)


class ProcStatus(_Found):
    """The probe's lines of ``/proc/self/status``."""

    cap_eff: str = Field(alias="CapEff", description="Effective capabilities (hex mask).")
    cap_prm: str = Field(alias="CapPrm", description="Permitted capabilities (hex mask).")
    no_new_privs: str = Field(alias="NoNewPrivs", description="'1': no-new-privileges is on.")
    seccomp: str = Field(alias="Seccomp", description="'2': a seccomp filter is on.")

    @property
    def capabilities(self) -> tuple[int, int]:
        """The effective and permitted capability masks."""
        return int(self.cap_eff, 16), int(self.cap_prm, 16)


class ProbeReport(_Found):
    """What the probe's ``report`` task saw: who it runs as, its environment, its inputs
    and its network interfaces."""

    uid: int
    euid: int
    gid: int
    status: ProcStatus
    env: dict[str, str]
    input_listing: list[str] = Field(description="The input folder's names.")
    interfaces: list[str] = Field(description="The names under /sys/class/net.")
    mounts: str = Field(description="/proc/self/mounts as the probe read it.")


class FilesystemFindings(_Found):
    """What each write of the ``filesystem`` task did: ``ok`` or ``failed: <why>``."""

    root: str
    etc: str
    input: str
    tmp_small: str = Field(description="A small file in /tmp.")
    tmp_past_cap: str = Field(description="A file in /tmp past the tmp_mb cap.")
    output: str


class ProbeFindings(_Found):
    """What the probe wrote to its output folder (``probe-result.json``); all empty when it
    wrote nothing."""

    done: list[str] = Field(default_factory=list, description="The tasks done, in order.")
    report: ProbeReport | None = None
    filesystem: FilesystemFindings | None = None
    network: dict[str, str | None] | None = Field(
        default=None, description="Each connection tried: None (nothing to try), 'ok' or "
        "'failed: <why>'.")
    forks: int | None = Field(default=None, description="Children the fork bomb got.")
    memory_mb: int | None = Field(default=None, description="MiB allocated and touched.")


def probe_build_context(folder: Path, base_image: str = "eagc/agent-base:latest") -> Path:
    """Writes a build context (Dockerfile + probe) for the probe image; returns ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(PROBE_SCRIPT, folder / "probe.py")
    (folder / "Dockerfile").write_text(
        "# The runtime conformance probe (_programs/runtime_probe.py), built offline.\n"
        f"FROM {base_image}\n"
        "COPY probe.py /app/probe.py\n"
        f"USER {CONTAINER.uid}:{CONTAINER.uid}\n"
        'CMD ["python3", "-u", "/app/probe.py"]\n'
    )
    return folder


@dataclass
class ProbeRun:
    """One probe agent: its launch, its handle and, once stopped, how it ended."""

    launch: AgentLaunch
    handle: AgentHandle
    exit: ContainerExit | None = None

    @property
    def output(self) -> Path:
        return self.launch.output_dir

    def found(self) -> ProbeFindings:
        """What the probe wrote (empty if it wrote nothing)."""
        path = self.output / _RESULT
        if not path.exists():
            return ProbeFindings()
        return ProbeFindings.model_validate_json(path.read_bytes())

    def heartbeat(self, name: str) -> float | None:
        """When the named child last touched its heartbeat file (None: never)."""
        path = self.output / f"heartbeat-{name}"
        return path.stat().st_mtime if path.exists() else None


class RuntimeConformance:
    """Checks what every agent runtime owes the episode worker.

    Subclass it in a ``Test*`` class and define the fixtures ``runtime`` and ``probe_image``.
    """

    #: Limits the probes run under (small, so that the limit tests are quick).
    limits: ClassVar[Limits] = Limits(cpus=1.0, memory_mb=128, pids=48, tmp_mb=8, log_mb=1)
    #: How long a probe may take to do its tasks.
    timeout_s: ClassVar[float] = 60.0
    #: An image (or command) that does not exist for the runtime under test.
    missing_image: ClassVar[str] = "eagc-conformance/no-such-image:never"

    # ----------------------------------------------------------------------- helpers
    @contextmanager
    def probe(
        self,
        runtime: AgentRuntime,
        image: str,
        tasks: list[dict[str, Any]],
        *,
        labels: Mapping[str, str] | None = None,
    ) -> Iterator[ProbeRun]:
        """Starts the probe with ``tasks`` the way the episode worker starts an agent (the
        same folders and modes); stops it and removes everything on the way out."""
        # Short on purpose: the socket folder's path must fit a unix socket path.
        root = Path(tempfile.mkdtemp(prefix="eagc-rt-", dir="/tmp"))
        sock, output, inputs = root / "sock", root / "output", root / "input"
        sock.mkdir()
        sock.chmod(0o755)
        inputs.mkdir()
        (inputs / "probe.json").write_text(json.dumps({"do": tasks}))
        inputs.chmod(0o755)
        (inputs / "probe.json").chmod(0o644)
        mounted = mount_output(output, self.limits.output_mb, CONTAINER.uid)
        launch = AgentLaunch(
            image=image, episode="rt" + secrets.token_hex(8), socket_dir=sock,
            output_dir=output, input_dir=inputs, limits=self.limits,
            labels=dict(labels or {}),
        )
        run: ProbeRun | None = None
        try:
            run = ProbeRun(launch, runtime.start(launch))
            yield run
        finally:
            if run is not None and run.exit is None:
                run.exit = run.handle.stop()
            if mounted:
                unmount_output(output)
            shutil.rmtree(root, ignore_errors=True)

    def run_to_end(
        self, runtime: AgentRuntime, image: str, tasks: list[dict[str, Any]]
    ) -> tuple[ContainerExit, ProbeFindings]:
        """Runs the probe until it exits by itself; returns how it ended and what it found."""
        with self.probe(runtime, image, tasks) as run:
            assert run.handle.wait(self.timeout_s), (
                f"the probe did not exit within {self.timeout_s} s (tasks {tasks})")
            run.exit = run.handle.stop()
            return run.exit, run.found()

    def await_done(self, run: ProbeRun, tasks: list[str]) -> None:
        """Waits until the probe has done ``tasks`` (while it keeps running)."""
        deadline = time.monotonic() + self.timeout_s
        while run.found().done != tasks:
            assert not run.handle.wait(0.1), f"the probe exited early: {run.handle.stop()}"
            assert time.monotonic() < deadline, f"the probe did not do {tasks}: {run.found()}"

    @staticmethod
    def _beat(run: ProbeRun, name: str) -> tuple[int, bytes] | None:
        """The named heartbeat's state: its mtime (ns) and content, the time its writer
        wrote last (None: not written yet). Any write changes it, whatever the clock's
        granularity."""
        path = run.output / f"heartbeat-{name}"
        try:
            return path.stat().st_mtime_ns, path.read_bytes()
        except FileNotFoundError:
            return None

    def _moves(self, run: ProbeRun, name: str) -> bool:
        """True as soon as the named heartbeat moves (its writer runs); False if it has not
        within ``timeout_s``. Polled: a child the machine is slow to schedule is not taken
        for one that never ran."""
        first = self._beat(run, name)
        deadline = time.monotonic() + self.timeout_s
        while time.monotonic() < deadline:
            time.sleep(0.05)
            if self._beat(run, name) != first:
                return True
        return False

    @classmethod
    def _goes_still(cls, run: ProbeRun, name: str, quiet_s: float = 1.0,
                    within_s: float = 15.0) -> bool:
        """True once the named heartbeat has not moved for ``quiet_s`` (its writer, which
        writes every 0.1 s, is gone); False if it still moves after ``within_s``. Polled: a
        kill that takes a moment to land is not taken for a survivor."""
        last, since = cls._beat(run, name), time.monotonic()
        deadline = since + within_s
        while True:
            time.sleep(0.05)
            now, at = cls._beat(run, name), time.monotonic()
            if now != last:
                last, since = now, at
            elif at - since >= quiet_s:
                return True
            if at >= deadline:
                return False

    # --------------------------------------------------------------------- the checks
    def test_exit_code_comes_back(self, runtime: AgentRuntime, probe_image: str) -> None:
        exit_, found = self.run_to_end(runtime, probe_image, [{"task": "exit", "code": 3}])
        assert found.done == ["exit"], f"the probe never ran its tasks: {exit_}"
        assert exit_.exit_code == 3, exit_
        assert not exit_.killed_by_host and not exit_.oom_killed, exit_

    def test_clean_exit(self, runtime: AgentRuntime, probe_image: str) -> None:
        exit_, _ = self.run_to_end(runtime, probe_image, [{"task": "exit", "code": 0}])
        assert exit_.exit_code == 0 and not exit_.killed_by_host, exit_

    def test_log_tail_holds_the_last_lines(self, runtime: AgentRuntime, probe_image: str) -> None:
        exit_, _ = self.run_to_end(
            runtime, probe_image, [{"task": "print", "lines": 2000}, {"task": "exit", "code": 0}]
        )
        assert "probe line 1999" in exit_.log_tail, exit_.log_tail[-300:]
        assert "probe line 0\n" not in exit_.log_tail, "the tail is not a tail"
        assert len(exit_.log_tail) <= 4000

    def test_stop_kills_a_hanging_agent(self, runtime: AgentRuntime, probe_image: str) -> None:
        with self.probe(runtime, probe_image, [{"task": "hang"}]) as run:
            self.await_done(run, ["hang"])
            assert not run.handle.wait(1.0), "a hanging agent was reported as exited"
            run.exit = run.handle.stop()
            assert run.exit.killed_by_host, run.exit
            assert run.exit.exit_code not in (None, 0), run.exit
            assert run.handle.wait(5.0), "the agent still runs after stop()"

    def test_stop_is_idempotent(self, runtime: AgentRuntime, probe_image: str) -> None:
        with self.probe(runtime, probe_image, [{"task": "hang"}]) as run:
            first = run.handle.stop()
            assert run.handle.stop() == first
            run.exit = first

    def test_environment_is_the_contract(self, runtime: AgentRuntime, probe_image: str) -> None:
        with self.probe(runtime, probe_image, [{"task": "report"}, {"task": "exit", "code": 0}]
                        ) as run:
            assert run.handle.wait(self.timeout_s)
            found = run.found()  # read from the host's folder: the agent wrote EAGC_OUTPUT
            episode = run.launch.episode
        assert found.report is not None, "the probe wrote no report to its output folder"
        env = found.report.env
        assert env[CONTAINER.env_episode] == episode
        assert env[CONTAINER.env_endpoint].startswith(unix_endpoint(""))
        assert env[CONTAINER.env_endpoint].endswith(f"/{CONTAINER.socket_name}")
        assert "probe.json" in found.report.input_listing
        for key in (CONTAINER.env_output, CONTAINER.env_input):
            assert env.get(key), f"{key} is not set"

    def test_children_die_with_the_agent(self, runtime: AgentRuntime, probe_image: str) -> None:
        with self.probe(runtime, probe_image,
                        [{"task": "spawn", "name": "child"}, {"task": "hang"}]) as run:
            self.await_done(run, ["spawn", "hang"])
            assert self._moves(run, "child"), "the child never ran"
            run.exit = run.handle.stop()
            assert self._goes_still(run, "child"), "a child of the agent outlived stop()"

    def test_runaway_memory_ends_the_agent(self, runtime: AgentRuntime, probe_image: str) -> None:
        exit_, found = self.run_to_end(
            runtime, probe_image,
            [{"task": "memory", "mb": self.limits.memory_mb * 8}, {"task": "exit", "code": 0}],
        )
        assert exit_.exit_code != 0, (
            f"the probe allocated {found.memory_mb} MiB under a "
            f"{self.limits.memory_mb} MiB limit and exited cleanly")

    def test_missing_image_is_the_agents_fault(self, runtime: AgentRuntime) -> None:
        try:
            with self.probe(runtime, self.missing_image, [{"task": "exit", "code": 0}]):
                pass
        except AgentStartError as e:
            assert str(e), "AgentStartError without a reason"
        else:
            raise AssertionError(f"{self.missing_image!r} started, or failed without "
                                 "AgentStartError")


class SandboxConformance(RuntimeConformance):
    """Adds the sandbox, checked from inside the agent (official runtimes)."""

    def test_runtime_is_official(self, runtime: AgentRuntime) -> None:
        assert runtime.official, f"{runtime.name} claims no sandbox (official=False)"

    def test_identity_and_privileges(self, runtime: AgentRuntime, probe_image: str) -> None:
        _, found = self.run_to_end(runtime, probe_image, [{"task": "report"}])
        rep = found.report
        assert rep is not None, f"the probe wrote no report: {found}"
        assert rep.uid != 0 and rep.euid != 0 and rep.gid != 0, rep
        status = rep.status
        assert status.capabilities == (0, 0), f"capabilities left: {status}"
        assert status.no_new_privs == "1", status
        assert status.seccomp == "2", f"no seccomp filter: {status}"

    def test_filesystem(self, runtime: AgentRuntime, probe_image: str) -> None:
        _, found = self.run_to_end(
            runtime, probe_image, [{"task": "filesystem", "tmp_mb": self.limits.tmp_mb}])
        fs = found.filesystem
        assert fs is not None, f"the probe wrote no filesystem findings: {found}"
        for place, result in (("root", fs.root), ("etc", fs.etc), ("input", fs.input)):
            assert result.startswith("failed"), f"the agent could write {place}: {fs}"
        assert fs.tmp_small == "ok" and fs.output == "ok", fs
        assert fs.tmp_past_cap.startswith("failed"), f"/tmp is not capped: {fs}"

    def test_no_network(self, runtime: AgentRuntime, probe_image: str) -> None:
        _, found = self.run_to_end(runtime, probe_image,
                                   [{"task": "report"}, {"task": "network"}])
        assert found.report is not None and found.network is not None, found
        assert found.report.interfaces in ([], ["lo"]), found.report.interfaces
        for target, result in found.network.items():
            assert result is None or result.startswith("failed"), (
                f"{target} reached from the sandbox: {result}")

    def test_nothing_of_the_host_leaks(self, runtime: AgentRuntime, probe_image: str) -> None:
        canary = "EAGC_CONFORMANCE_CANARY"
        os.environ[canary] = secrets.token_hex(8)
        try:
            with self.probe(runtime, probe_image, [{"task": "report"}]) as run:
                assert run.handle.wait(self.timeout_s)
                rep = run.found().report
                host_root = str(run.output.parent)
        finally:
            value = os.environ.pop(canary)
        assert rep is not None, "the probe wrote no report"
        env = rep.env
        contract = {CONTAINER.env_endpoint, CONTAINER.env_episode, CONTAINER.env_output,
                    CONTAINER.env_input}
        assert canary not in env
        extra = [k for k in env
                 if k not in contract and k not in _IMAGE_ENV and not k.startswith("LC_")]
        assert not extra, f"variables beyond the contract and the image's own: {extra}"
        assert env[CONTAINER.env_endpoint] == unix_endpoint(CONTAINER.socket_path)
        assert env[CONTAINER.env_output] == CONTAINER.output_dir
        assert env[CONTAINER.env_input] == CONTAINER.input_dir
        assert value not in rep.model_dump_json()
        assert host_root not in json.dumps(env), "a host path in the agent's environment"

    def test_pids_limit_holds_a_fork_bomb(self, runtime: AgentRuntime, probe_image: str) -> None:
        exit_, found = self.run_to_end(
            runtime, probe_image, [{"task": "forks", "count": self.limits.pids * 4}])
        assert found.forks is not None, f"the probe died forking: {exit_}"
        assert found.forks < self.limits.pids, (
            f"{found.forks} processes under a pids limit of {self.limits.pids}")

    def test_oom_kill_is_reported(self, runtime: AgentRuntime, probe_image: str) -> None:
        exit_, _ = self.run_to_end(
            runtime, probe_image, [{"task": "memory", "mb": self.limits.memory_mb * 8}])
        assert exit_.oom_killed, exit_
        assert exit_.peak_memory_bytes is not None
        assert exit_.peak_memory_bytes >= (self.limits.memory_mb << 20) * 0.9, exit_

    def test_detached_daemons_die_with_the_agent(
        self, runtime: AgentRuntime, probe_image: str
    ) -> None:
        tasks = [{"task": "spawn", "name": "daemon", "detached": True}, {"task": "exit", "code": 0}]
        with self.probe(runtime, probe_image, tasks) as run:
            assert run.handle.wait(self.timeout_s)
            run.exit = run.handle.stop()
            assert run.heartbeat("daemon") is not None, "the daemon never ran"
            assert self._goes_still(run, "daemon"), "a detached daemon outlived the agent"

    def test_cleanup_finds_leftovers(self, runtime: AgentRuntime, probe_image: str) -> None:
        mark = {"campaign": "conformance-" + secrets.token_hex(4)}
        with self.probe(runtime, probe_image, [{"task": "hang"}], labels=mark) as run:
            removed = runtime.cleanup(mark)
            assert len(removed) == 1, f"cleanup({mark}) removed {removed}"
            assert run.handle.wait(10.0), "the agent still runs after cleanup()"
            run.exit = run.handle.stop()  # the worker may still stop an agent the reaper took
            assert runtime.cleanup(mark) == []


# ------------------------------------------------------------------- a track's hooks
@dataclass(frozen=True)
class PlayedCampaign:
    """A short campaign of a track, played: its spec, where its store and pages are, and
    each episode's folder."""

    spec: Any
    store: Path
    folders: tuple[Path, ...]


class TrackEpisodeConformance:
    """Checks a track's hooks on real episodes (module doc). Subclass it in a ``Test*``
    class and set ``track`` and ``agent``."""

    #: The track under test (an installed or a ``plugins.registered_track`` one).
    track: ClassVar[str]
    #: A command that plays one episode of the track (run by the local runtime).
    agent: ClassVar[str]
    #: The split played (None: the track's first) and its parameters.
    split: ClassVar[str | None] = None
    params: ClassVar[Mapping[str, Any]] = {}
    #: One episode per team.
    teams: ClassVar[tuple[str, ...]] = ("team-a", "team-b")
    #: The campaign's limits (``schemas.Limits`` fields).
    limits: ClassVar[Mapping[str, Any]] = {"max_steps_per_stage": 200, "startup_s": 60.0,
                                           "pin_cpus": False}
    _played: ClassVar[dict[type, PlayedCampaign]] = {}

    def played(self) -> PlayedCampaign:
        """The campaign, played once per class (folders under /tmp: short socket paths)."""
        if type(self) not in self._played:
            self._played[type(self)] = self._play()
        return self._played[type(self)]

    def _play(self) -> PlayedCampaign:
        import yaml

        from orchestrator._campaign.seeds import commitment, load_secret, seed_list
        from orchestrator._campaign.spec import campaign_dir, load_campaign, plan, store_path
        from orchestrator._episode.worker import EpisodeSpec, run_episode
        from orchestrator._results.store import ResultsStore
        from orchestrator._runtimes.local import LocalProcessRuntime
        from plugins import load_track

        plugin = load_track(self.track)
        split = self.split or next(iter(plugin.splits))
        folder = Path(tempfile.mkdtemp(prefix="eagc-tc-", dir="/tmp"))
        doc = {"name": f"conformance-{self.track}", "track": self.track, "phase": "local",
               "runtime": "local", "retries": 0, "output": str(folder / "out"),
               "splits": [{"name": split, "weight": 1.0, "episodes": 1,
                           "params": dict(self.params)}],
               "submissions": [{"team": t, "image": self.agent} for t in self.teams],
               "limits": dict(self.limits)}
        (folder / "campaign.yaml").write_text(yaml.safe_dump(doc))
        spec = load_campaign(folder / "campaign.yaml")
        seeded = seed_list(spec, load_secret(spec))
        seeds = {(s.split, s.index): s.seed for s in seeded}
        runs = campaign_dir(spec)
        runs.mkdir(parents=True, mode=0o700)
        folders = []
        with ResultsStore(store_path(spec)) as store:
            keys = plan(spec)
            store.register(spec, commitment(spec, seeded), len(keys))
            for key in keys:
                result = run_episode(EpisodeSpec(
                    track=self.track, image=self.agent, seed=seeds[(key.split, key.index)],
                    split=key.split, params=dict(self.params), limits=spec.limits,
                    runs_dir=runs, index=key.index,
                    labels={"campaign": spec.name, "submission": key.submission}),
                    LocalProcessRuntime(quiet=True))
                assert result.episode_dir is not None, result.failure
                store.commit(spec.name, key, result, retry=0, node=None)
                folders.append(Path(result.episode_dir))
        return PlayedCampaign(spec, store_path(spec), tuple(folders))

    def _store(self) -> Any:
        from orchestrator._results.store import ResultsStore

        return ResultsStore(self.played().store)

    # ---------------------------------------------------------------------- the checks
    def test_every_episode_is_scored_by_the_track(self) -> None:
        with self._store() as store:
            stored = store.results(self.played().spec.name)
        assert len(stored) == len(self.teams), stored
        for e in stored:
            assert e.result.status.value == "completed", (e.key, e.result.failure)
            assert e.result.score.track == self.track, e.result.score

    def test_the_leaderboard_has_a_row_per_team(self) -> None:
        from orchestrator._results.leaderboard import build_leaderboard

        with self._store() as store:
            board = build_leaderboard(self.played().spec, store)
        assert sorted(r.team for r in board.rows) == sorted(self.teams), board.rows
        assert all(r.values.get("final") is not None for r in board.rows), board.rows
        for fmt in ("table", "csv", "json", "md"):
            assert board.render(fmt, 120).strip(), fmt

    def test_the_pages_show_the_tracks_map_pictures_and_truth(self) -> None:
        from orchestrator._viewer.episode import read_episode
        from orchestrator._viewer.site import write_campaign_site
        from plugins import RecordedEpisode, load_track

        plugin = load_track(self.track)
        out = Path(tempfile.mkdtemp(prefix="eagc-tc-site-"))
        try:
            with self._store() as store:
                pages = write_campaign_site(self.played().spec, store, out, organizer=True)
            assert len(pages) >= 2 + len(self.played().folders), pages
        finally:
            shutil.rmtree(out, ignore_errors=True)
        for folder in self.played().folders:
            for organizer in (False, True):
                view = read_episode(folder, organizer=organizer)
                hooks = [p for p in view.problems if p.startswith(("no map", "no model-vs"))]
                assert not hooks, hooks
                episode = RecordedEpisode(folder, _scenario_of(folder), organizer)
                shown = plugin.episode_map(episode)
                assert (view.map_image is not None) == (shown is not None)
                if shown is not None and view.map_frame is not None:
                    size = (view.map_frame["height"], view.map_frame["width"])
                    assert size == shown.rgb.shape[:2], (size, shown.rgb.shape)
                for picture in view.pictures:
                    assert 0 <= picture["from"] <= picture["to"] <= view.last_step, picture
                if organizer:
                    truth = plugin.truth(episode)
                    assert view.truth == ([] if truth is None else list(truth.lines))
                else:
                    assert view.hidden is None and not view.truth and view.picture is None

    def test_the_audit_replays_the_episode_and_runs_the_tracks_checks(self) -> None:
        from orchestrator._episode.audit import audit_episode, track_checks
        from plugins import EpisodeChecks, Finding

        checks = track_checks(self.track)
        assert checks is None or isinstance(checks, EpisodeChecks)
        for folder in self.played().folders:
            audit = audit_episode(folder)
            assert audit.track == self.track and audit.host_steps > 0
            assert audit.replay is not None and audit.replay.ok, audit.replay
            assert all(isinstance(f, Finding) for f in audit.findings)

    def test_the_protocol_page_gets_the_tracks_section(self) -> None:
        from plugins import load_track, protocol_doc

        page = protocol_doc.render("<!-- end tracks -->\n", tracks=[self.track])
        assert f"### Track `{self.track}`" in page
        assert f"<!-- end generated:track:{self.track} -->" in page
        assert load_track(self.track).vocabulary().strip() in page


def _scenario_of(folder: Path) -> Any:
    from simhost.host import read_scenario

    scenario = read_scenario(folder / "host" / "episode.mcap")
    assert scenario is not None, f"{folder}: no scenario in the log"
    return scenario
