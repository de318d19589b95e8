"""The watchdog around ``SimHost.serve()``: a hung episode ends as an infrastructure
failure with every thread's stack in its folder, instead of holding its worker forever.

An unknown hang cannot be produced on demand, so one is injected: the sanity episode's
``step`` blocks forever inside the track's code (a real sim host, a real agent process and
real Zenoh around it). Everything else is the real worker.
"""

from __future__ import annotations

import tempfile
import threading
from pathlib import Path
from typing import Any

import pytest

import plugins
from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._runtimes.local import LocalProcessRuntime
from schemas import EpisodeStatus, Limits

AGENT = Path(__file__).resolve().parents[2] / "examples" / "sanity_agent" / "agent.py"


def hung_step(*args: Any, **kwargs: Any) -> Any:
    threading.Event().wait()  # forever: nothing ever sets it


def test_a_hung_sim_host_ends_as_an_infrastructure_failure(
        monkeypatch: pytest.MonkeyPatch) -> None:
    track = plugins.load_track("sanity")
    make_episode = track.make_episode

    def hanging_episode(scenario: Any) -> Any:
        episode = make_episode(scenario)
        episode.step = hung_step  # type: ignore[method-assign]
        return episode

    monkeypatch.setattr(type(track), "make_episode", lambda self, s: hanging_episode(s))
    runs = Path(tempfile.mkdtemp(prefix="eagc-wd-", dir="/tmp"))
    # Budgets of 0.6 s per stage (time_scale 0.01), 8 s to start, 3 s of grace.
    spec = EpisodeSpec(track="sanity", image=f"python {AGENT}", seed=3, runs_dir=runs,
                       limits=Limits(time_scale=0.01, startup_s=8), watchdog_grace_s=3.0,
                       exit_grace_s=1.0)
    results: list[Any] = []
    worker = threading.Thread(
        target=lambda: results.append(run_episode(spec, LocalProcessRuntime(quiet=True))),
        daemon=True)
    worker.start()
    worker.join(120)  # without the watchdog, run_episode never returns
    assert results, "run_episode still runs two minutes after every budget ended"
    (result,) = results
    assert result.status is EpisodeStatus.INFRA_ERROR, result.failure
    assert result.failure is not None and "watchdog" in result.failure.message
    dump = Path(result.episode_dir) / "host" / "watchdog.txt"
    assert "hung_step" in dump.read_text(), "the stack dump does not show where it hung"
    assert (Path(result.episode_dir) / "host" / "result.json").exists()
