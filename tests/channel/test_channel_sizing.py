"""A phase sized from the previous phase's data (issue 34 §2): `eagc campaign plan` on the
qualification's paired spreads proposes the final's episodes and their cost; approved
under a cost cap before the final opens, they become its campaign's. On the channel's real
database and results store, the clock injected."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_channel_rules import T0
from test_team_page import _accept, _passed, _result

from orchestrator._campaign.plan import plan_campaign
from orchestrator._channel.channel import Channel
from orchestrator._channel.db import ChannelError, Clock
from orchestrator._channel.registry import RegistryProcess
from schemas import ChallengeSpec, EpisodeRow, Outcome, Submission

SPLITS = [{"name": "standard", "episodes": 8, "weight": 0.6},
          {"name": "challenge", "episodes": 8, "weight": 0.4}]
SPEC = ChallengeSpec.model_validate({
    "name": "sizing", "track": "track1", "teams": ["team-a", "team-b", "team-c"],
    "phases": [{"name": "qual", "closes": "start+1d", "splits": SPLITS,
                "quota": {"per_day": 5, "concurrent": 3}},
               {"name": "final", "opens": "start+2d", "closes": "start+3d",
                "splits": SPLITS}]})


def _qualified(tmp_path: Path) -> Channel:
    ch = Channel(SPEC, tmp_path / "d", clock=Clock(origin=T0, speed=0.0))
    ch.add_spec_teams()
    ch.registry = RegistryProcess(tmp_path / "reg", ch.keys, realm="http://unused", port=5999)
    rng = np.random.default_rng(7)
    for team, mean in (("team-a", 0.6), ("team-b", 0.5), ("team-c", 0.45)):
        sid = _accept(ch, team, "qual")
        _passed(ch, sid)
        assert ch.claim("r", "run") is not None
        rows = tuple(EpisodeRow(split=s["name"], index=i, result=_result(
            s["name"], float(np.clip(mean + rng.normal(0, 0.15), 0, 1))))
            for s in SPLITS for i in range(8))
        ch.report(sid, Outcome(runner="r", kind="run", ok=True, wall_s=60.0, results=rows))
    return ch


def test_the_final_is_sized_from_the_qualifications_data(tmp_path: Path) -> None:
    ch = _qualified(tmp_path)
    final, qual = ch.phase("final"), ch.phase("qual")
    pilot = ch.pilot(qual)
    assert sorted(pilot) == ["team-a", "team-b", "team-c"] and len(pilot["team-a"]) == 16
    teams = tuple(Submission(team=f"t{i}", image="none") for i in range(3))
    plan = plan_campaign(ch.campaign(final, ch.data / "runs", teams), resolve=10.0,
                         pilot=pilot, pilot_name="phase qual")
    assert plan.spread_source.startswith("pilot phase qual (3 teams")
    needed = {s.name: s.episodes_needed for s in plan.splits}
    with pytest.raises(ChannelError, match="over the cap of 0.001 h"):
        ch.approve_sizing(final, plan, cost_cap_h=0.001, who="org", why="too tight")
    ch.approve_sizing(final, plan, cost_cap_h=1000, who="org", why="resolve 10 points")
    sized = ch.campaign(final, ch.data / "runs")
    assert {s.name: s.episodes for s in sized.splits} == needed
    assert ch.campaign(qual, ch.data / "runs").splits[0].episodes == 8  # untouched
    assert ch.sizing(final)["resolve"] == 10.0  # type: ignore[index]
    assert ch.db.actions()[-1][2] == "sizing"
    ch.clock.origin += 2 * 86400  # the final opens: its episodes, and seeds, are final
    with pytest.raises(ChannelError, match="opened .*: its episodes, and so its seeds"):
        ch.approve_sizing(final, plan, cost_cap_h=1000, who="org", why="too late")
