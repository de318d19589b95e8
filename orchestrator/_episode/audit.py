"""Auditing one episode from its folder: replay, log steps, and the track's file checks.

``audit_episode(folder)`` reads the episode's MCAP log (what the host recorded: every
request, every reply with its observation JSON and messages, the small observation
tensors, the events), replays it (``replay --verify``; the replay also yields what the log
does not keep, such as the segmentation image), and checks the agent's files:

- **log steps** (every track, ``log_step_findings``): each ``episode_log.jsonl`` record's
  ``step`` against the host's step count: never past the steps the host had served, and
  within the steps of the stage the record names; a ``world_model.json``'s ``step`` alike.
- **the track's checks**, when its plugin has some (``TrackPlugin.audit``: a fresh
  ``plugins.EpisodeChecks`` per episode, e.g. Track 1's early detections and ids never
  shown): fed what the agent was shown, step by step (``observe(step, data, tensors)``,
  ``message(step, message)`` with a ``schemas.HostMessage``, ``action(step, action,
  result)`` with the checked action and a ``schemas.ActionResult``), then asked for its
  ``findings`` on a ``plugins.AuditInput`` (the scenario, the host's events in log order,
  the snapshots, the final log's records, the host's steps).

What the agent was shown comes from the log's replies (observation JSON, messages, action
results) and small tensors, and from the replay's observations (every tensor, the
segmentation image included): one pass over the log, one re-simulation.

The functions are pure where they can be (``log_step_findings``, ``HostSteps``), so that a
team-facing report can say the same from the same code.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, computed_field

from orchestrator._episode.replay import ReplayError, replay
from plugins import (
    STEP_SLACK,
    AuditInput,
    EpisodeChecks,
    Finding,
    HostSteps,
    Severity,
    Snapshot,
    load_track,
    log_step_findings,
)
from schemas import LogRecord, ObservationReply, SchemaError, parse_episode_log
from simhost.host import (
    HostEventModel,
    McapRecordError,
    ScenarioRecord,
    SmallTensors,
    StageEndEvent,
    StageStartEvent,
    StepRequest,
    read_records,
    read_scenario,
)

_TOPICS = ["/eagc/scenario", "/eagc/request", "/eagc/reply", "/eagc/observation",
           "/eagc/event"]
__all__ = ["STEP_SLACK", "EpisodeAudit", "Finding", "HostSteps", "ReplayCheck", "Severity",
           "audit_episode", "log_step_findings"]


class ReplayCheck(BaseModel):
    """``replay --verify`` of one episode."""

    model_config = ConfigDict(frozen=True)

    ok: bool
    steps: int = 0
    hashes_checked: int = 0
    states_checked: int = 0
    mismatches: tuple[str, ...] = ()
    error: str | None = None


class EpisodeAudit(BaseModel):
    """Everything the audit found on one episode."""

    model_config = ConfigDict(frozen=True)

    episode: str
    folder: str
    track: str
    host_steps: int
    replay: ReplayCheck | None
    findings: tuple[Finding, ...] = ()

    @computed_field  # type: ignore[prop-decorator]
    @property
    def flagged(self) -> bool:
        return (any(f.severity == "flag" for f in self.findings)
                or (self.replay is not None and not self.replay.ok))


class EpisodeAuditError(ReplayError):
    """Raised when an episode folder has no readable log to audit."""


def track_checks(track: str) -> EpisodeChecks | None:
    """A fresh set of the track's own checks for one episode (``TrackPlugin.audit``), or
    None when it has none."""
    return load_track(track).audit()


@dataclass
class _Log:
    """What the audit reads of an MCAP log."""

    scenario: ScenarioRecord
    events: list[HostEventModel]
    host: HostSteps


def _read_log(path: Path, checks: EpisodeChecks | None) -> _Log:
    """Reads the log once, feeding ``checks`` (None: no track checks) as it goes."""
    scenario: ScenarioRecord | None = None
    events: list[HostEventModel] = []
    steps = 0
    stages: dict[str, list[int]] = {}
    action: dict[str, Any] | None = None
    for record in read_records(path, _TOPICS):
        match record.body:
            case ScenarioRecord() as scenario:
                pass
            case StepRequest() as step:
                steps += 1
                action = step.action
            case StageStartEvent(stage=stage) as event:
                events.append(event)
                stages[stage] = [steps, steps]
            case StageEndEvent(stage=stage) as event:
                events.append(event)
                stages.setdefault(stage, [steps, steps])[1] = steps
            case ObservationReply() as reply if checks is not None:
                checks.observe(steps, reply.observation, {})
                for m in reply.messages:
                    checks.message(steps, m)
                if action is not None and reply.action is not None:
                    checks.action(steps, action, reply.action)
                action = None
            case SmallTensors(values=tensors) if checks is not None:
                checks.observe(steps, {}, tensors)
            case body if record.topic == "/eagc/event":
                events.append(body)
    if scenario is None:
        raise EpisodeAuditError(f"{path}: no /eagc/scenario message: not an eagc episode log")
    return _Log(scenario, events, HostSteps(steps, {k: (v[0], v[1]) for k, v in stages.items()}))


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()} \
        if folder.is_dir() else {}


def _log_records(blob: bytes | None) -> tuple[list[LogRecord], Finding | None]:
    if blob is None:
        return [], Finding(check="log_steps", severity="note",
                           message="no episode_log.jsonl at the end: nothing to check")
    try:
        return parse_episode_log(blob), None
    except SchemaError as e:
        return [], Finding(check="log_steps", severity="note", message=(
            f"episode_log.jsonl does not parse ({e.summary}): not checked"))


def _world_model_step(name: str, blob: bytes | None, step: int) -> Finding | None:
    """A ``world_model.json`` that names a step past the host's count at its snapshot."""
    try:
        written = json.loads(blob).get("step") if blob is not None else None
    except (ValueError, AttributeError):
        return None
    if isinstance(written, int) and not isinstance(written, bool) \
            and written > step + STEP_SLACK:
        return Finding(check="log_steps", severity="flag", step=written, message=(
            f"{name}: world_model.json says step {written}; the host had served {step}"))
    return None


def audit_episode(folder: Path | str, *, verify: bool = True) -> EpisodeAudit:
    """Audits one episode folder (``<runs>/<episode>``; module doc)."""
    folder = Path(folder)
    mcap = folder / "host" / "episode.mcap"
    if not mcap.is_file():
        raise EpisodeAuditError(f"{folder}: no host/episode.mcap to audit")
    try:
        first = read_scenario(mcap)
        if first is None:
            raise EpisodeAuditError(
                f"{mcap}: no /eagc/scenario message: not an eagc episode log")
        track = first.track
        checks = track_checks(track)
        log = _read_log(mcap, checks)
    except McapRecordError as e:
        raise EpisodeAuditError(str(e)) from None

    check: ReplayCheck | None = None
    if verify:
        def seen(steps: int, obs: Any) -> None:
            if checks is not None:
                checks.observe(steps, {}, obs.tensors)

        try:
            report = replay(mcap, on_observation=seen)
            check = ReplayCheck(ok=report.ok, steps=report.steps,
                                hashes_checked=report.hashes_checked,
                                states_checked=report.states_checked,
                                mismatches=tuple(report.mismatches))
        except Exception as e:  # noqa: BLE001 - a replay that crashes is a finding
            check = ReplayCheck(ok=False, error=f"{type(e).__name__}: {e}".splitlines()[0])

    findings: list[Finding] = []
    snapshots: list[Snapshot] = []
    for stage in log.host.stages:
        files = _files(folder / "host" / "snapshots" / stage)
        if files:
            snapshots.append(Snapshot(stage, log.host.at_end(stage), files))
    final = _files(folder / "host" / "output")
    snapshots.append(Snapshot("final", log.host.total, final))
    for snap in snapshots:
        bad = _world_model_step(snap.name, snap.files.get("world_model.json"), snap.step)
        if bad is not None:
            findings.append(bad)
    records, problem = _log_records(final.get("episode_log.jsonl"))
    findings += [problem] if problem is not None else log_step_findings(records, log.host)
    if checks is not None:
        findings += checks.findings(AuditInput(
            scenario=log.scenario, events=tuple(log.events), snapshots=tuple(snapshots),
            log=tuple(records), host=log.host))
    return EpisodeAudit(episode=log.scenario.episode,
                        folder=str(folder), track=track, host_steps=log.host.total,
                        replay=check, findings=tuple(findings))
