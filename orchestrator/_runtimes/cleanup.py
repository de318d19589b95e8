"""``eagc cleanup``: what dead episodes left behind, and nothing of a live one.

Safe at any time, while other campaigns run:

* without ``--campaign``, an agent (container or local process) is removed only when its
  episode is dead: its heartbeat (``orchestrator._runtimes.reaper``) is readable here and stale, or,
  for a local agent of this machine, its episode folder is gone. A container without a
  heartbeat this machine can read is never touched;
* ``--campaign NAME`` removes every agent of that campaign (its driver must be stopped);
* ``--runs DIR`` also tidies the folders of killed attempts under DIR (an ``ep…`` folder with
  no ``host/result.json`` whose heartbeat is stale or gone): their output mount is released
  and the folder removed, or, with ``keep_logs``, everything but ``host/`` (the partial MCAP
  and the snapshots) removed;
* ``dry_run`` only says what would go.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from orchestrator._runtimes.engine import managed_containers
from orchestrator._runtimes.interface import LABEL_PREFIX
from orchestrator._runtimes.reaper import HEARTBEAT_LABEL, STALE_S, heartbeat_age


@dataclass
class CleanupPlan:
    """What ``eagc cleanup`` removes (or would, with ``--dry-run``)."""

    containers: list[str] = field(default_factory=list)
    local_agents: list[str] = field(default_factory=list)
    folders: list[str] = field(default_factory=list)
    mounts: list[str] = field(default_factory=list)
    kept_live: int = 0  # agents left alone: their episode is alive or cannot be told
    notes: list[str] = field(default_factory=list)


def _dead(heartbeat: str | None, *, local: bool) -> bool:
    if not heartbeat:
        return False
    age = heartbeat_age(heartbeat)
    if age is None:  # unreadable: for a local agent, its folder is gone with its episode
        return local and not Path(heartbeat).parent.exists()
    return age >= STALE_S


def _mounts_under(folder: Path) -> list[str]:
    root = os.path.realpath(folder) + os.sep
    try:
        lines = Path("/proc/self/mounts").read_text().splitlines()
    except OSError:
        return []
    return [p[1] for p in (line.split() for line in lines)
            if len(p) > 1 and p[0] == "eagc-output" and (p[1] + os.sep).startswith(root)]


#: Written into ``host/`` of a killed attempt tidied with ``keep_logs``.
KILLED_MARK = "attempt_killed.txt"


def killed_attempts(runs: Path, *, keep_logs: bool = False) -> list[Path]:
    """Episode folders under ``runs`` (a campaign folder or a runs folder, one level of
    campaigns deep) with no result whose heartbeat is stale or gone."""
    found = []
    for ep in sorted([*runs.glob("ep*"), *runs.glob("*/ep*")]):
        if not ep.is_dir() or (ep / "host" / "result.json").exists():
            continue
        if keep_logs and (ep / "host" / KILLED_MARK).exists():
            continue  # tidied before
        if not (ep / "host").is_dir():
            continue
        age = heartbeat_age(ep / "heartbeat")
        if age is None or age >= STALE_S:
            found.append(ep)
    return found


def cleanup(*, campaign: str | None = None, runs: Path | None = None, dry_run: bool = False,
            keep_logs: bool = False, client: Any = None) -> CleanupPlan:
    """Removes (or, ``dry_run``, lists) what dead episodes left; see the module doc."""
    plan = CleanupPlan()
    _remove_containers(plan, campaign=campaign, dry_run=dry_run, client=client)
    _stop_local_agents(plan, campaign=campaign, dry_run=dry_run)
    if runs is not None:
        _tidy_killed_attempts(plan, runs, dry_run=dry_run, keep_logs=keep_logs)
    return plan


def _remove_containers(plan: CleanupPlan, *, campaign: str | None, dry_run: bool,
                       client: Any) -> None:
    """Containers of dead episodes (every one of ``campaign``), through the Docker engine."""
    if client is None:
        from orchestrator._runtimes.docker import docker_client

        try:
            client = docker_client()
        except Exception as e:  # noqa: BLE001 - no engine: local agents and folders only
            plan.notes.append(f"no Docker engine: containers not looked at ({e})")
            return
    filters = [f"{LABEL_PREFIX}.managed=true"]
    if campaign is not None:
        filters.append(f"{LABEL_PREFIX}.campaign={campaign}")
    for c in managed_containers(client, filters):
        if campaign is None and not _dead((c.labels or {}).get(HEARTBEAT_LABEL), local=False):
            plan.kept_live += 1
            continue
        plan.containers.append(c.name)
        if not dry_run:
            try:
                c.remove(force=True)
            except Exception as e:  # noqa: BLE001 - gone meanwhile
                plan.notes.append(f"{c.name}: {e}")


def _stop_local_agents(plan: CleanupPlan, *, campaign: str | None, dry_run: bool) -> None:
    """Local agent processes of dead episodes (every one of ``campaign``)."""
    from orchestrator._runtimes.local import LocalMark, kill_local_agents, local_agents

    labels = {} if campaign is None else {"campaign": campaign}

    def dead(mark: LocalMark) -> bool:
        return campaign is not None or _dead(mark.heartbeat, local=True)

    if not dry_run:
        plan.local_agents = [f"pid {pid}" for pid, _ in kill_local_agents(labels, only=dead)]
        return
    for pid, mark in local_agents():
        if mark.matches(labels):
            if dead(mark):
                plan.local_agents.append(f"pid {pid}")
            else:
                plan.kept_live += 1


def _tidy_killed_attempts(plan: CleanupPlan, runs: Path, *, dry_run: bool,
                          keep_logs: bool) -> None:
    """The folders of killed attempts under ``runs``: output mounts released, then the
    folder removed, or, with ``keep_logs``, all of it but ``host/``."""
    for ep in killed_attempts(runs, keep_logs=keep_logs):
        plan.folders.append(str(ep))
        for mount in _mounts_under(ep):
            plan.mounts.append(mount)
            if not dry_run:
                subprocess.run(["umount", "-l", mount], capture_output=True)
        if dry_run:
            continue
        if keep_logs:
            _keep_only_host(ep)
        else:
            shutil.rmtree(ep, ignore_errors=True)


def _keep_only_host(ep: Path) -> None:
    """Removes all of a killed attempt's folder but ``host/`` (the partial MCAP log and the
    snapshots), and says so there."""
    for child in ep.iterdir():
        if child.name != "host":
            if child.is_dir() and not child.is_symlink():
                shutil.rmtree(child, ignore_errors=True)
            else:
                child.unlink(missing_ok=True)
    (ep / "host" / KILLED_MARK).write_text(
        "This attempt's worker died before it wrote a result; `eagc cleanup "
        "--keep-logs` removed all but host/ (the partial MCAP log).\n")
