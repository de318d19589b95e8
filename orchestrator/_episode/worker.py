"""The episode worker: scenario → sim host → agent → /output → checks → score → result.

``run_episode`` never raises for something an agent or the engine did: every ending is an
``EpisodeResult`` with a status. Agent failures (crash, OOM, timeout, protocol violation, bad
files, never started) come from the engine's own state and the host's clock, never from what
the agent printed; infrastructure failures (engine or host errors) are ``infra_error`` and may
be retried by the caller.

Episode folder (organizer side; the agent sees only ``sock/``, ``output/`` and ``input/``)::

    <runs>/<episode>/sock/zenoh.sock     mounted read-only at /run/eagc
    <runs>/<episode>/output/             mounted at /output (size-capped tmpfs when root)
    <runs>/<episode>/input/              mounted read-only at /input, when the track has inputs
    <runs>/<episode>/host/               episode.mcap, result.json, snapshots/, agent.log
    <runs>/<episode>/heartbeat           touched while the episode runs (_runtimes.reaper)

The episode folder is private (0700): its MCAP log holds the hidden scenario. The agent's
mounts are bind mounts of its subfolders, which the engine resolves as root.

A watchdog bounds ``SimHost.serve()``: past the sum of the stage budgets plus startup and
``watchdog_grace_s``, every thread's stack goes to ``host/watchdog.txt``, the host is told
to stop, and if ``serve()`` still has not returned 10 s later it is abandoned; either way
the episode ends as an infrastructure failure (retried), never as the agent's.
"""

from __future__ import annotations

import json
import logging
import secrets
import shutil
import sys
import threading
import time
import traceback
from collections.abc import Mapping
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from orchestrator._episode.collect import collect, mount_output, unmount_output
from orchestrator._runtimes.cpus import placed
from orchestrator._runtimes.interface import (
    AgentHandle,
    AgentLaunch,
    AgentRuntime,
    AgentStartError,
)
from orchestrator._runtimes.reaper import Heartbeat, reap_here
from plugins import EpisodeOutcome, Scenario, TrackPlugin, load_track, score_episode
from schemas import (
    CONTAINER,
    ContainerExit,
    EndReason,
    EpisodeResult,
    EpisodeStats,
    EpisodeStatus,
    FailureReport,
    FileCheck,
    Limits,
    unix_endpoint,
)
from simhost.host import HostConfig, HostOutcome, McapRecorder, SimHost

log = logging.getLogger("eagc.worker")



@dataclass(frozen=True)
class EpisodeSpec:
    """One episode to run. The seed is hidden: it never reaches the agent."""

    track: str
    image: str
    seed: int
    split: str = "standard"
    params: Mapping[str, Any] = field(default_factory=dict)
    limits: Limits = Limits()
    runs_dir: Path = Path("runs")
    labels: Mapping[str, str] = field(default_factory=dict)
    episode: str | None = None
    exit_grace_s: float = 10.0
    #: The episode's index within its split in a campaign (None: a one-off episode).
    index: int | None = None
    #: How long past its budgets (startup + stages) a host may serve before the watchdog.
    watchdog_grace_s: float = 120.0


def stack_dump() -> str:
    """Every thread's stack, named, as text (what the watchdog writes)."""
    names = {t.ident: t.name for t in threading.enumerate()}
    out = []
    for ident, frame in sys._current_frames().items():
        out.append(f"--- thread {names.get(ident, '?')} ({ident})\n"
                   + "".join(traceback.format_stack(frame)))
    return "\n".join(out)


def serve_watched(host: SimHost, stop: threading.Event, deadline_s: float,
                  dump: Path) -> tuple[HostOutcome, str | None, bool]:
    """``host.serve(stop)`` on a thread of its own, bounded by ``deadline_s``.

    Returns the outcome, why the watchdog fired if it did (the stacks are in ``dump``), and
    whether ``serve()`` is still running (abandoned: the episode must not be closed under
    it)."""
    got: list[HostOutcome] = []
    failed: list[BaseException] = []

    def run() -> None:
        try:
            got.append(host.serve(stop))
        except BaseException as e:  # noqa: BLE001 - handed to the caller
            failed.append(e)

    thread = threading.Thread(target=run, daemon=True, name=f"serve-{host.config.episode}")
    thread.start()
    try:
        thread.join(deadline_s)
    except BaseException:  # cancelled (KeyboardInterrupt from Ray): stop serving first
        stop.set()
        thread.join(10.0)
        raise
    if not thread.is_alive():
        if failed:
            raise failed[0]
        return got[0], None, False
    stacks = stack_dump()
    dump.write_text(f"watchdog: serve() still ran {deadline_s:.0f} s after the episode "
                    f"started, past every budget\n\n{stacks}")
    log.error("episode %s: watchdog fired; stacks in %s", host.config.episode, dump)
    stop.set()
    thread.join(10.0)
    why = (f"watchdog: the sim host still served {deadline_s:.0f} s after the start, past "
           f"every budget (stacks in {dump.name})")
    outcome = got[0] if got else HostOutcome()
    return outcome, why, thread.is_alive()


def new_episode_id() -> str:
    """An opaque id: nothing about the campaign, split, seed or team."""
    return "ep" + secrets.token_hex(8)


class _Snapshots:
    """Copies /output's files at every stage end (and at exit) into the host folder."""

    def __init__(self, output: Path, host: Path, limits: Limits, recorder: McapRecorder) -> None:
        self.output = output
        self.dir = host / "snapshots"
        self.limits = limits
        self.recorder = recorder
        self.by_stage: dict[str, dict[str, bytes]] = {}

    def take(self, stage: str) -> dict[str, bytes]:
        got = collect(
            self.output,
            max_file_bytes=self.limits.output_file_mb << 20,
            max_total_bytes=self.limits.output_mb << 20,
        )
        self.by_stage[stage] = got.files
        folder = self.dir / stage
        folder.mkdir(parents=True, exist_ok=True)
        for name, blob in got.files.items():
            (folder / name).write_bytes(blob)
            self.recorder.write_raw(f"/eagc/file/{stage}/{name}", self.recorder.now(), blob)
        return got.files


def _classify(
    outcome: HostOutcome, exit_: ContainerExit, limits: Limits, checks: list[FileCheck]
) -> tuple[EpisodeStatus, str | None, str]:
    """(status, limit hit, message) from the host's clock and the engine's state."""
    reason = outcome.end_reason
    stage = outcome.last_stage or "startup"
    if outcome.internal_error:
        return EpisodeStatus.INFRA_ERROR, None, "the sim host failed (not the agent's fault)"
    if exit_.oom_killed:
        return (EpisodeStatus.AGENT_OOM, f"memory {limits.memory_mb} MiB",
                f"the container was killed for exceeding its memory limit during {stage!r}")
    if reason == EndReason.PROTOCOL_VIOLATION:
        return (EpisodeStatus.AGENT_PROTOCOL, f"{limits.max_protocol_errors} protocol errors",
                "too many malformed or invalid requests")
    if reason in (EndReason.STOPPED, EndReason.AGENT_LOST):
        if exit_.exit_code == 0:  # no crash: it ended cleanly, too soon
            return (EpisodeStatus.AGENT_CRASH, None,
                    f"the agent exited with code 0 before the episode ended, during {stage!r}")
        how = "exited" if exit_.exit_code is not None else "disconnected"
        return (EpisodeStatus.AGENT_CRASH, None,
                f"the agent {how} (exit code {exit_.exit_code}) before the episode ended, "
                f"during {stage!r}")
    if reason == EndReason.STARTUP_TIMEOUT:
        if outcome.agent_seen:
            msg = "the agent said hello but did not reset within the startup budget"
        else:
            msg = "the agent never connected within the startup budget"
        return EpisodeStatus.AGENT_TIMEOUT, f"startup {limits.startup_s:g} s", msg
    if reason == EndReason.BUDGET:
        limit = f"stage budget of {stage!r}"
        quiet = None  # seconds from the agent's last request to the end
        if outcome.last_request_at is not None and outcome.ended_at is not None:
            quiet = outcome.ended_at - outcome.last_request_at
        if quiet is not None and quiet >= max(5.0, outcome.stage_durations_s.get(stage, 0) / 2):
            return (EpisodeStatus.AGENT_TIMEOUT, limit, f"the agent sent no request for "
                    f"{quiet:.0f} s (stage {stage!r} ran out of time)")
        return (EpisodeStatus.AGENT_TIMEOUT, limit,
                f"the last stage {stage!r} ran out of time before the agent finished")
    # The last stage's step budget used up (EndReason.STEPS) is an ordinary end: the task
    # is scored as far as it got, and the agent did nothing wrong.
    bad = [c for c in checks if not c.ok]
    if bad:
        return (EpisodeStatus.AGENT_BAD_FILES, None,
                "; ".join(f"{c.name}: {c.reason.splitlines()[0]}" for c in bad))
    return EpisodeStatus.COMPLETED, None, "completed"


def _latency(outcome: HostOutcome) -> tuple[float | None, float | None]:
    if not outcome.latencies_s:
        return None, None
    arr = np.asarray(outcome.latencies_s) * 1000
    return float(np.median(arr)), float(np.percentile(arr, 99))


@dataclass(frozen=True)
class _Folders:
    """An episode's folders (``<runs>/<episode>/``: see the module docstring)."""

    root: Path
    sock: Path
    output: Path
    host: Path
    socket: Path


@dataclass
class _Served:
    """What serving an episode left: its scenario, the host's outcome, the agent's exit,
    the track's organizer-side outcome, and what went wrong outside the agent's doing."""

    scenario: Scenario[Any] | None = None
    outcome: HostOutcome = field(default_factory=HostOutcome)
    exit_: ContainerExit = field(default_factory=ContainerExit)
    #: ``TrackEpisode.outcome()`` (None: the episode never got that far, or it failed).
    episode_outcome: EpisodeOutcome | None = None
    infra: str | None = None
    no_start: str | None = None


def run_episode(spec: EpisodeSpec, runtime: AgentRuntime) -> EpisodeResult:
    """Runs one episode to the end and returns its result; never raises for agent faults.

    prepare (folders, heartbeat, /output) → serve (scenario, host, agent) → collect
    (/output, snapshots, file checks) → score (``plugins.score_episode``) → keep (result,
    MCAP, log, the agent's files)."""
    started = time.time()
    plugin = load_track(spec.track)
    episode_id = spec.episode or new_episode_id()
    folders = _prepare(spec, episode_id)
    # Docker agents: the heartbeat names them for the reapers, which run from here too.
    heartbeat = Heartbeat(folders.root / "heartbeat",
                          reap=(lambda: reap_here()) if runtime.name == "docker" else None)
    mounted = mount_output(folders.output, spec.limits.output_mb, CONTAINER.uid)
    recorder = McapRecorder(folders.host / "episode.mcap")
    snapshots = _Snapshots(folders.output, folders.host, spec.limits, recorder)
    served = _serve(spec, runtime, plugin, episode_id, folders, recorder, snapshots, heartbeat)

    # ------------------------------------------------------------ files and score
    final = collect(folders.output, max_file_bytes=spec.limits.output_file_mb << 20,
                    max_total_bytes=spec.limits.output_mb << 20)
    snapshots.by_stage["final"] = final.files
    parsed, checks = plugin.verify_files(final.files)
    checks = checks + final.refused
    snap_parsed = {stage: plugin.parse_snapshot(files)
                   for stage, files in snapshots.by_stage.items() if stage != "final"}
    outcome, exit_ = served.outcome, served.exit_
    if served.infra is not None:
        status, limit = EpisodeStatus.INFRA_ERROR, None
        message = served.infra.strip().splitlines()[-1]
    elif served.no_start is not None:
        status, limit, message = EpisodeStatus.AGENT_NO_START, None, served.no_start
    else:
        status, limit, message = _classify(outcome, exit_, spec.limits, checks)
    score = score_episode(
        plugin, served.scenario, status=status, end_reason=outcome.end_reason,
        stages_reached=outcome.stages_reached, outcome=served.episode_outcome, files=parsed,
        snapshots=snap_parsed, steps=outcome.steps, invalid_actions=outcome.invalid_actions,
        protocol_errors=sum(n for code, n in outcome.protocol_errors.items()
                            if code != "invalid_action"),
        time_scale=spec.limits.time_scale)

    median, p99 = _latency(outcome)
    stats = EpisodeStats(
        steps=outcome.steps,
        invalid_actions=outcome.invalid_actions,
        protocol_errors=dict(outcome.protocol_errors),
        latency_ms_median=median,
        latency_ms_p99=p99,
        peak_memory_bytes=exit_.peak_memory_bytes,
        wall_s=time.time() - started,
        stage_durations_s=outcome.stage_durations_s,
        sim_warnings=0 if served.episode_outcome is None else served.episode_outcome.sim_warnings,
    )
    failure = None
    if status.failure_kind is not None:
        failure = FailureReport(
            kind=status.failure_kind, status=status, stage_reached=outcome.last_stage,
            limit_hit=limit, exit_code=exit_.exit_code, oom_killed=exit_.oom_killed,
            message=message, log_tail=exit_.log_tail[-2000:],
        )
    result = EpisodeResult(
        episode=episode_id, track=spec.track, split=spec.split, image=spec.image,
        runtime=runtime.name, status=status, score=score, stats=stats, files=tuple(checks),
        stages_reached=tuple(outcome.stages_reached), failure=failure, container=exit_,
        episode_dir=str(folders.root), mcap=str(folders.host / "episode.mcap"),
        started_at=started, finished_at=time.time(),
    )
    recorder.write_json("/eagc/score", recorder.now(), result.model_dump(mode="json"))
    recorder.close()
    _keep(folders, result, exit_, served.infra, final.files, mounted)
    return result


def _prepare(spec: EpisodeSpec, episode_id: str) -> _Folders:
    """The episode's folders, made (private: the MCAP holds the hidden scenario)."""
    root = spec.runs_dir.resolve() / episode_id
    sock, output, host = root / "sock", root / "output", root / "host"
    socket_path = sock / CONTAINER.socket_name
    if len(str(socket_path)) > CONTAINER.max_socket_path:
        raise ValueError(
            f"socket path {socket_path} is longer than {CONTAINER.max_socket_path} bytes "
            "(a unix socket limit): choose a shorter runs folder"
        )
    for d in (sock, host):
        d.mkdir(parents=True, exist_ok=True)
    root.chmod(0o700)
    sock.chmod(0o755)
    return _Folders(root, sock, output, host, socket_path)


def _serve(spec: EpisodeSpec, runtime: AgentRuntime, plugin: TrackPlugin[Any, Any],
           episode_id: str, folders: _Folders, recorder: McapRecorder, snapshots: _Snapshots,
           heartbeat: Heartbeat) -> _Served:
    """Builds the scenario, opens the sim host, starts the agent and serves the episode
    to its end; whatever happens, the agent is stopped and the host closed."""
    served = _Served()
    host: SimHost | None = None
    handle: AgentHandle | None = None
    input_dir: Path | None = None
    abandoned = False  # serve() hung and still runs: its episode is left open
    cores = ExitStack()  # the episode's cores, held until its host and agent are gone
    try:
        extra = {} if spec.index is None else {"index": spec.index}
        scenario = plugin.make_scenario(seed=spec.seed, split=spec.split, params=spec.params,
                                        **extra)
        served.scenario = scenario
        placement = cores.enter_context(placed(spec.limits.cpus, enabled=spec.limits.pin_cpus))
        recorder.write_json("/eagc/scenario", 0.0, {
            "episode": episode_id, "track": spec.track, "split": spec.split, "seed": spec.seed,
            "image": spec.image, "params": scenario.params, "limits": spec.limits.model_dump(),
            "cpus": None if placement is None else placement.as_dict(),
        })
        staged = folders.root / "input"
        staged.mkdir()
        plugin.write_inputs(scenario, staged)
        if any(staged.iterdir()):
            input_dir = staged
        episode = plugin.make_episode(scenario)
        host = SimHost(
            episode,
            plugin.stages(),
            HostConfig(
                episode=episode_id,
                track=spec.track,
                endpoints=(unix_endpoint(str(folders.socket)),),
                socket_path=folders.socket,
                time_scale=spec.limits.time_scale,
                max_steps_per_stage=spec.limits.max_steps_per_stage,
                startup_s=spec.limits.startup_s,
                max_request_bytes=spec.limits.max_request_kb * 1024,
                max_protocol_errors=spec.limits.max_protocol_errors,
            ),
            recorder=recorder,
            on_stage_end=snapshots.take,
        )
        host.open()
        budgets = sum(s.budget_s for s in plugin.stages()) * spec.limits.time_scale
        watchdog_s = spec.limits.startup_s + budgets + spec.watchdog_grace_s
        launch = AgentLaunch(
            image=spec.image, episode=episode_id, socket_dir=folders.sock,
            output_dir=folders.output, input_dir=input_dir, limits=spec.limits,
            labels=spec.labels, cpuset=None if placement is None else placement.cpuset,
            heartbeat=heartbeat.path, deadline_s=watchdog_s + spec.exit_grace_s + 30.0,
        )
        try:
            handle = runtime.start(launch)
        except AgentStartError as e:
            served.no_start = str(e)
        if handle is not None:
            stop = threading.Event()
            exited = threading.Event()

            def watch(h: AgentHandle = handle) -> None:
                h.wait(None)
                exited.set()
                stop.set()

            threading.Thread(target=watch, daemon=True, name=f"watch-{episode_id}").start()
            outcome, hung, abandoned = serve_watched(host, stop, watchdog_s,
                                                     folders.host / "watchdog.txt")
            served.outcome = outcome
            if hung is not None:
                served.infra = hung
            handle.checkpoint()  # while the agent most likely still runs
            if outcome.end_reason != EndReason.STOPPED and not exited.is_set():
                # Let the agent write its last files and leave on its own.
                handle.wait(spec.exit_grace_s)
            exit_ = handle.stop()
            if outcome.end_reason == EndReason.STOPPED and exit_.exit_code is not None:
                exit_ = exit_.model_copy(update={"exited_early": True})
            served.exit_ = exit_
            if outcome.internal_error and served.infra is None:
                served.infra = outcome.internal_error
    except Exception as e:  # noqa: BLE001 - the result must be recorded whatever happened
        served.infra = "".join(traceback.format_exception(e))
        log.error("episode %s: infrastructure failure\n%s", episode_id, served.infra)
    finally:
        if handle is not None:
            try:
                stopped = handle.stop()  # the same exit, unless serving never stopped it
                if not served.exit_.exited_early:
                    served.exit_ = stopped
            except Exception as e:  # noqa: BLE001
                served.infra = served.infra or f"could not stop the agent: {e}"
        heartbeat.stop()
        if host is not None:
            host.close()
            try:
                if not abandoned:
                    host.episode.close()
            except Exception:  # noqa: BLE001
                pass
        cores.close()
    if host is not None:
        try:
            served.episode_outcome = host.episode.outcome()
        except Exception as e:  # noqa: BLE001
            log.error("episode %s: outcome() failed: %s", episode_id, e)
    return served


def _keep(folders: _Folders, result: EpisodeResult, exit_: ContainerExit, infra: str | None,
          files: dict[str, bytes], mounted: bool) -> None:
    """Writes the result and the agent's log and files into ``host/``; releases /output."""
    (folders.host / "result.json").write_text(result.model_dump_json(indent=2))
    (folders.host / "agent.log").write_text(exit_.log_tail)
    if infra is not None:
        (folders.host / "infra_error.txt").write_text(infra)
    # Keep a copy of what the agent left (regular files only), then release the tmpfs.
    keep = folders.host / "output"
    keep.mkdir(exist_ok=True)
    for name, blob in files.items():
        (keep / name).write_bytes(blob)
    if mounted:
        unmount_output(folders.output)
    shutil.rmtree(folders.sock, ignore_errors=True)


def result_json(result: EpisodeResult) -> str:
    return json.dumps(result.model_dump(mode="json"), indent=2)
