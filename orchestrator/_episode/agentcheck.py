"""The agent conformance check a team runs on its image before submitting (``eagc test``).

It runs one real episode of a track in the official sandbox (public seed, budgets scaled
down) and checks the container contract point by point, so that a team learns why its
container would fail before an organizer's campaign does.
"""

from __future__ import annotations

from dataclasses import dataclass

from orchestrator._results.score_card import file_lines
from schemas import EpisodeResult, EpisodeStatus


@dataclass(frozen=True)
class Check:
    """One point of the contract: ``ok`` is None where the episode ended before it could
    be judged (the cause is the one failing line above it)."""

    name: str
    ok: bool | None
    detail: str = ""


#: Statuses that end an episode before its end: one cause, the later checks not reached.
_CUT_SHORT = (EpisodeStatus.AGENT_NO_START, EpisodeStatus.AGENT_CRASH,
              EpisodeStatus.AGENT_TIMEOUT, EpisodeStatus.AGENT_OOM,
              EpisodeStatus.AGENT_PROTOCOL, EpisodeStatus.INFRA_ERROR)


def _last_line(result: EpisodeResult) -> str:
    tail = result.failure.log_tail if result.failure else ""
    lines = [line.strip() for line in tail.splitlines() if line.strip()]
    return lines[-1] if lines else ""


def _cause(result: EpisodeResult) -> tuple[str, str]:
    """(the check that failed, why) for an episode cut short."""
    message = result.failure.message if result.failure else result.status.value
    status = result.status
    if status is EpisodeStatus.AGENT_NO_START:
        return "the container starts", message
    if status is EpisodeStatus.AGENT_OOM:
        return "not OOM-killed", message
    if status is EpisodeStatus.AGENT_PROTOCOL:
        return "no protocol errors", message
    if status is EpisodeStatus.AGENT_CRASH:
        last = _last_line(result)
        message += f"; its last line: {last}" if last else "; it printed nothing"
    if not result.stages_reached:
        return "it connects, says hello and resets", message
    return "it steps through every stage", message


def contract_checks(result: EpisodeResult) -> list[Check]:
    """What the contract asks, judged from one episode's result: one failing line for one
    cause, the checks after it not reached (None) when the episode was cut short."""
    s = result.stats
    exit_ = result.container
    errors = {k: v for k, v in s.protocol_errors.items() if k != "invalid_action"}
    checks = [
        Check("the container starts", True),
        Check("it connects, says hello and resets", True),
        Check("it steps through every stage", s.steps > 0,
              "" if s.steps else f"status {result.status.value}, no step"),
        Check("no protocol errors", not errors, ", ".join(f"{k}: {v}" for k, v in errors.items())),
        Check("its files are there and valid", all(f.ok for f in result.files)
              and bool(result.files),
              "\n".join(f"{f.name}: {line}" for f in result.files if not f.ok
                        for line in file_lines(f.reason) or ["rejected"])),
        Check("it exits by itself when the episode is over",
              exit_ is not None and not exit_.killed_by_host and exit_.exit_code == 0,
              "" if exit_ is None else f"exit code {exit_.exit_code}"
              + (", killed by the host" if exit_.killed_by_host else "")),
        Check("not OOM-killed", exit_ is None or not exit_.oom_killed),
    ]
    if result.status not in _CUT_SHORT:
        return checks
    if result.status is EpisodeStatus.INFRA_ERROR:
        return [Check(c.name, None, "not judged") for c in checks]
    name, why = _cause(result)
    at = next(i for i, c in enumerate(checks) if c.name == name)
    return [Check(c.name, True) if i < at
            else Check(c.name, False, why) if i == at
            else Check(c.name, None, "not reached") for i, c in enumerate(checks)]


def verdict(result: EpisodeResult, checks: list[Check]) -> str:
    """The one-line verdict under the contract table."""
    if result.status is EpisodeStatus.INFRA_ERROR:
        return "verdict: not judged: the infrastructure failed (not the agent's fault)"
    failed = [c for c in checks if c.ok is False]
    if not failed:
        return "verdict: the container meets the contract"
    first = failed[0]
    if len(failed) > 1:
        return f"verdict: {len(failed)} checks fail, first: {first.name}"  # <= 80 columns
    return f"verdict: fails the contract ({result.status.value}): {first.name}"
