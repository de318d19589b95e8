"""Local agents never outlive their worker, and `eagc cleanup` finds the ones that could.

Real processes: a worker process running a real episode (sim host, Zenoh) with an agent
that never connects; the worker is killed with SIGKILL, as a lost Ray worker would be.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from typer.testing import CliRunner

from orchestrator._runtimes.interface import AgentLaunch
from orchestrator._runtimes.local import MARK, LocalMark, LocalProcessRuntime, local_agents
from orchestrator.cli import app
from schemas import Limits

SLEEPER = f"{sys.executable} -c 'import time; time.sleep(600)'"

WORKER = """
import sys
from pathlib import Path
from orchestrator._runtimes.local import LocalProcessRuntime
from orchestrator._episode.worker import EpisodeSpec, run_episode
from schemas import Limits
run_episode(EpisodeSpec(track="sanity", image=sys.argv[1], seed=1, runs_dir=Path(sys.argv[2]),
                        episode=sys.argv[3], limits=Limits(startup_s=600)),
            LocalProcessRuntime(quiet=True))
"""


def _agent_of(episode: str) -> int | None:
    for pid, mark in local_agents():
        if mark.matches({"episode": episode}):
            return pid
    return None


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _wait(check: object, timeout: float) -> bool:
    deadline = time.time() + timeout
    while time.time() < deadline:
        if check():  # type: ignore[operator]
            return True
        time.sleep(0.1)
    return False


def test_a_local_agent_dies_with_its_worker() -> None:
    runs = Path(tempfile.mkdtemp(prefix="eagc-lo-", dir="/tmp"))
    episode = "ep" + os.urandom(8).hex()
    worker = subprocess.Popen([sys.executable, "-c", WORKER, SLEEPER, str(runs), episode],
                              env={**os.environ, "MUJOCO_GL": "egl"})
    try:
        assert _wait(lambda: _agent_of(episode) is not None, 60), "the agent never started"
        agent = _agent_of(episode)
        assert agent is not None and _alive(agent)
        worker.kill()  # SIGKILL: no finally block, no stop() in the worker
        worker.wait(10)
        assert _wait(lambda: not _alive(agent), 10), "the agent outlived its worker"
    finally:
        if worker.poll() is None:
            worker.kill()
        pid = _agent_of(episode)
        if pid is not None:
            os.killpg(pid, signal.SIGKILL)


def _launch(runs: Path, campaign: str, episode: str, heartbeat: Path | None) -> AgentLaunch:
    (runs / episode).mkdir(parents=True)
    return AgentLaunch(image=SLEEPER, episode=episode, socket_dir=runs / episode,
                       output_dir=runs / episode, limits=Limits(),
                       labels={"campaign": campaign}, heartbeat=heartbeat)


def test_cleanup_finds_dead_local_agents_and_leaves_live_ones() -> None:
    """An agent whose episode's heartbeat is stale is killed by `eagc cleanup`; one whose
    heartbeat is fresh is left alone; `--campaign` takes all of that campaign's agents."""
    runs = Path(tempfile.mkdtemp(prefix="eagc-lc-", dir="/tmp"))
    campaign = "lc-" + os.urandom(4).hex()
    runtime = LocalProcessRuntime(quiet=True)
    stale_hb, live_hb = runs / "dead" / "heartbeat", runs / "live" / "heartbeat"
    dead = runtime.start(_launch(runs, campaign, "dead", stale_hb))
    live = runtime.start(_launch(runs, campaign, "live", live_hb))
    try:
        stale_hb.touch()
        os.utime(stale_hb, (time.time() - 120, time.time() - 120))
        live_hb.touch()
        cli = CliRunner()
        dry = cli.invoke(app, ["cleanup", "--dry-run"])
        assert dry.exit_code == 0, dry.output
        assert f"pid {dead.id}" in dry.output and f"pid {live.id}" not in dry.output
        assert _alive(int(dead.id))  # a dry run removes nothing
        done = cli.invoke(app, ["cleanup"])
        assert done.exit_code == 0, done.output
        assert _wait(lambda: not _alive(int(dead.id)), 5)
        assert _alive(int(live.id)), "cleanup killed the agent of a live episode"
        named = cli.invoke(app, ["cleanup", "--campaign", campaign])
        assert named.exit_code == 0 and f"pid {live.id}" in named.output
        assert _wait(lambda: not _alive(int(live.id)), 5)
    finally:
        dead.stop()
        live.stop()


def test_cleanup_tidies_killed_attempts_folders() -> None:
    """`eagc cleanup --runs DIR`: a killed attempt's folder (no result, stale heartbeat) is
    removed, or reduced to its host/ with --keep-logs; a finished episode's and a live
    one's are left alone."""
    runs = Path(tempfile.mkdtemp(prefix="eagc-kf-", dir="/tmp")) / "camp"
    for name in ("epkilled", "epdone", "eplive"):
        for sub in ("host", "sock", "output"):
            (runs / name / sub).mkdir(parents=True)
        (runs / name / "host" / "episode.mcap").write_bytes(b"partial")
        (runs / name / "sock" / "zenoh.sock").write_bytes(b"")
        (runs / name / "heartbeat").touch()
    (runs / "epdone" / "host" / "result.json").write_text("{}")
    old = time.time() - 600
    for name in ("epkilled", "epdone"):
        os.utime(runs / name / "heartbeat", (old, old))
    cli = CliRunner()
    dry = cli.invoke(app, ["cleanup", "--runs", str(runs.parent), "--dry-run"])
    assert dry.exit_code == 0 and "would remove 1 killed attempt folder(s)" in dry.output
    assert (runs / "epkilled" / "sock").exists()
    kept = cli.invoke(app, ["cleanup", "--runs", str(runs.parent), "--keep-logs"])
    assert kept.exit_code == 0, kept.output
    assert sorted(p.name for p in (runs / "epkilled").iterdir()) == ["host"]
    assert (runs / "epkilled" / "host" / "episode.mcap").read_bytes() == b"partial"
    again = cli.invoke(app, ["cleanup", "--runs", str(runs.parent), "--keep-logs"])
    assert "removed 0 killed attempt folder(s)" in again.output  # tidied once only
    gone = cli.invoke(app, ["cleanup", "--runs", str(runs.parent)])
    assert gone.exit_code == 0 and not (runs / "epkilled").exists()
    for name in ("epdone", "eplive"):
        assert (runs / name / "sock" / "zenoh.sock").exists(), name


def test_a_local_agent_is_found_by_its_mark_and_a_foreign_mark_is_ignored() -> None:
    """The mark in an agent's environment reads back as a LocalMark (labels, heartbeat);
    a process whose variable holds something else is no agent of ours."""
    runs = Path(tempfile.mkdtemp(prefix="eagc-lm-", dir="/tmp"))
    campaign = "lm-" + os.urandom(4).hex()
    heartbeat = runs / "ep" / "heartbeat"
    agent = LocalProcessRuntime(quiet=True).start(_launch(runs, campaign, "ep", heartbeat))
    foreign = subprocess.Popen(["sleep", "600"], env={**os.environ, MARK: '{"labels": 7}'})
    try:
        marks = dict(local_agents())
        mark = marks[int(agent.id)]
        assert mark == LocalMark(labels={"episode": "ep", "campaign": campaign},
                                 heartbeat=str(heartbeat))
        assert mark.matches({"campaign": campaign})
        assert not mark.matches({"campaign": campaign, "submission": "other"})
        assert foreign.pid not in marks
    finally:
        agent.stop()
        foreign.kill()
        foreign.wait()
