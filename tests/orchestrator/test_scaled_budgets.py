"""A scaled episode is scored against the budgets it was granted, not the official ones.

A Track 2 episode run with ``time_scale`` 0.1 (as the demo and ``eagc test`` do) grants its
demonstration and parsing stages a tenth of the official 5 + 20 minutes; the adaptation
component measures the adaptation time against those 150 s. The plugin's ``score`` is
wrapped to keep the ``ScoringInput`` the worker built (a spy: the real scorer still runs).
"""

from __future__ import annotations

import dataclasses
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._runtimes.local import LocalProcessRuntime
from plugins import ScoringInput, granted_budgets, load_track
from plugins.track2 import _scoring
from plugins.track2._outcome import Track2Outcome
from plugins.track2._track import Track2
from schemas import EpisodeStatus, Limits

SCALE = 0.1


@pytest.fixture()
def runs() -> Iterator[Path]:
    folder = Path(tempfile.mkdtemp(prefix="eagc-sc-", dir="/tmp"))  # short: socket paths
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def test_a_scaled_track2_episode_is_scored_against_its_scaled_budgets(
        runs: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[ScoringInput] = []
    real = Track2.score

    def spy(self: Any, data: ScoringInput) -> Any:
        seen.append(data)
        return real(self, data)

    monkeypatch.setattr(Track2, "score", spy)
    spec = EpisodeSpec(track="track2", image="python examples/track2_taskmodel/agent.py",
                       seed=4101, split="standard", index=1,
                       params={"demo_frames": False, "max_attempts": 1},
                       limits=Limits(startup_s=60.0, pin_cpus=False, time_scale=SCALE),
                       runs_dir=runs, exit_grace_s=5.0)
    result = run_episode(spec, LocalProcessRuntime(quiet=True))
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    assert len(seen) == 1
    data = seen[0]
    official = {s.name: s.budget_s for s in load_track("track2").stages()}
    assert data.stage_budgets_s == pytest.approx({k: v * SCALE for k, v in official.items()})
    assert data.stage_budgets_s == granted_budgets(load_track("track2").stages(), SCALE)

    # The card's adaptation is the scaled one: re-score the same episode as a success on its
    # first attempt after 60 s of adaptation: 0.6 + 0.4 * (1 - 60 / 150), not / 1500.
    won = Track2Outcome.model_validate(dict(data.outcome)).model_copy(
        update={"success": True, "success_attempt": 1, "adapt_time_s": 60.0})
    card = real(load_track("track2"), dataclasses.replace(
        data, outcome=won.model_dump(mode="json")))
    assert card.components["adaptation"] == pytest.approx(0.6 + 0.4 * (1 - 60 / 150))
    assert _scoring.granted_adapt_s(data.stage_budgets_s) == pytest.approx(150.0)
