"""The development runtime: the same worker with the agent as a plain process."""

from __future__ import annotations

import tempfile
from pathlib import Path

from orchestrator._episode.agentcheck import contract_checks
from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._runtimes.local import LocalProcessRuntime
from schemas import EpisodeStatus, Limits

AGENT = Path(__file__).resolve().parents[2] / "examples" / "sanity_agent" / "agent.py"


def _runs() -> Path:
    return Path(tempfile.mkdtemp(prefix="eagc-", dir="/tmp"))


def test_sanity_episode_as_a_local_process() -> None:
    result = run_episode(
        EpisodeSpec(track="sanity", image=f"python {AGENT}", seed=7, split="challenge",
                    runs_dir=_runs()),
        LocalProcessRuntime(quiet=True),
    )
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    assert result.runtime == "local"
    assert result.score.total > 0.5
    assert {f.name for f in result.files if f.ok} == {"world_model.json", "episode_log.jsonl"}
    failed = [c for c in contract_checks(result) if not c.ok]
    assert failed == []


def test_a_command_that_does_not_exist_never_starts() -> None:
    result = run_episode(
        EpisodeSpec(track="sanity", image="/nonexistent/agent", seed=1, runs_dir=_runs()),
        LocalProcessRuntime(quiet=True),
    )
    assert result.status is EpisodeStatus.AGENT_NO_START
    assert result.score.total == 0.0
    checks = {c.name: c for c in contract_checks(result)}
    assert not checks["the container starts"].ok
    assert "cannot start" in checks["the container starts"].detail


def test_step_caps_end_stages_whatever_the_machine_speed() -> None:
    # A 3-step cap per stage: the baseline cannot finish, the outcome is the same anywhere.
    result = run_episode(
        EpisodeSpec(track="sanity", image=f"python {AGENT}", seed=7, split="challenge",
                    limits=Limits(max_steps_per_stage=3), runs_dir=_runs()),
        LocalProcessRuntime(quiet=True),
    )
    # Using up the last stage's step budget is an ordinary end (scored), not an agent failure.
    assert result.status is EpisodeStatus.COMPLETED and result.failure is None
    assert "the last stage 'reach' used its step budget" in " ".join(result.score.notes)
    assert result.stats.steps <= 6
