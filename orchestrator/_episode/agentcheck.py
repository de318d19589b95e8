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
    name: str
    ok: bool
    detail: str = ""


def contract_checks(result: EpisodeResult) -> list[Check]:
    """What the contract asks, judged from one episode's result."""
    s = result.stats
    exit_ = result.container
    errors = {k: v for k, v in s.protocol_errors.items() if k != "invalid_action"}
    checks = [
        Check("the container starts", result.status is not EpisodeStatus.AGENT_NO_START,
              result.failure.message if result.status is EpisodeStatus.AGENT_NO_START
              and result.failure else ""),
        Check("it connects, says hello and resets", bool(result.stages_reached),
              "" if result.stages_reached else "no reset arrived within the startup budget"),
        Check("it steps through every stage",
              result.status in (EpisodeStatus.COMPLETED, EpisodeStatus.AGENT_BAD_FILES)
              and s.steps > 0,
              f"status {result.status.value}, {s.steps} steps"),
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
    return checks
