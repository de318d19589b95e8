"""Audit findings hold a phase's release until an organizer rules on each, and the team
concerned may appeal a ruling within its window; then each team's report, then the public
board. On the channel's real database and results store, the clock injected."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from test_channel_rules import T0
from test_team_page import SPEC, _accept, _passed, _score

from orchestrator._channel.channel import Channel
from orchestrator._channel.db import ChannelError, Clock
from orchestrator._channel.registry import RegistryProcess
from orchestrator._channel.release import add_findings, appeal, holds, release, rule


def _scored_phase(tmp_path: Path) -> Channel:
    ch = Channel(SPEC, tmp_path / "d", clock=Clock(origin=T0, speed=0.0))
    ch.add_spec_teams()
    ch.registry = RegistryProcess(tmp_path / "reg", ch.keys, realm="http://unused", port=5999)
    for team, base in (("team-a", 0.70), ("team-b", 0.30)):
        sid = _accept(ch, team, "final try")
        _passed(ch, sid)
        _score(ch, sid, base, None)
    return ch


def test_findings_hold_the_release_until_ruled_and_past_their_appeal(
        tmp_path: Path) -> None:
    ch = _scored_phase(tmp_path)
    phase = ch.open_phase()
    row = ch.counted(phase)["team-a"]
    add_findings(ch, phase, "team-a", row.id, ["standard/1: the replay does not match the "
                                               "log"], who="audit")
    out = tmp_path / "release"
    with pytest.raises(ChannelError, match="waits for a ruling") as held:
        release(ch, phase, out, who="org", why="phase over")
    assert held.value.status == 409 and not out.exists()  # nothing written while held
    (f,) = [int(h.split()[1]) for h in holds(ch, phase.name)]
    rule(ch, f, "accept", who="alice", why="a known MuJoCo warm-start difference")
    with pytest.raises(ChannelError, match="may appeal until 2026-05-03"):
        release(ch, phase, out, who="org", why="phase over")
    # The team appeals within the window: the finding waits for a new ruling.
    appeal(ch, f, "team-a", "our rerun matched; please look again")
    with pytest.raises(ChannelError, match="waits for a ruling after its appeal"):
        release(ch, phase, out, who="org", why="phase over")
    rule(ch, f, "disqualify", who="alice", why="the rerun diverged too")
    with pytest.raises(ChannelError, match="appealed already"):  # one appeal a finding
        appeal(ch, f, "team-a", "again")
    with pytest.raises(ChannelError) as theirs:
        appeal(ch, f, "team-b", "not ours")
    assert theirs.value.status == 404
    ch.clock.origin += ch.spec.appeal_s + 1
    written = release(ch, phase, out, who="org", why="phase over")
    # The teams' reports first, the public board last.
    assert written[-3:] == [out / "board.json", out / "board.md", out / "index.html"]
    board = json.loads((out / "board.json").read_text())
    assert [r["team"] for r in board["rows"]] == ["team-b"]  # team-a disqualified
    assert board["disqualified"] == ["team-a"]
    mine = json.loads((out / "teams" / "team-a.json").read_text())
    assert mine["disqualified"] and mine["audit"][0]["ruling"] == "disqualify"
    assert "team-a" not in (out / "board.md").read_text()
    acts = [a for _, _, a, _, _ in ch.db.actions()]
    assert acts[-4:] == ["audit", "rule", "rule", "release"]


def test_a_ruling_is_one_of_three_and_late_appeals_are_refused(tmp_path: Path) -> None:
    ch = _scored_phase(tmp_path)
    phase = ch.open_phase()
    add_findings(ch, phase, "team-b", ch.counted(phase)["team-b"].id, ["x"], who="audit")
    (f,) = [int(h.split()[1]) for h in holds(ch, phase.name)]
    with pytest.raises(ChannelError, match="one of accept, rerun, disqualify"):
        rule(ch, f, "ignore", who="a", why="b")
    with pytest.raises(ChannelError, match="no ruling yet"):
        appeal(ch, f, "team-b", "early")
    rule(ch, f, "rerun", who="a", why="run it again")
    ch.clock.origin += ch.spec.appeal_s + 1
    with pytest.raises(ChannelError, match="appeal window of finding .* closed"):
        appeal(ch, f, "team-b", "late")
    assert holds(ch, phase.name) == []


def test_the_public_page_shows_the_tracks_columns_disclosures_and_baselines(
        tmp_path: Path) -> None:
    from test_team_page import SPEC

    ch = _scored_phase(tmp_path)
    ch.spec = SPEC.model_copy(update={"baselines": ("team-b",)})
    phase = ch.open_phase()
    board = ch.board(phase)
    (b,) = [r for r in board.rows if r.team == "team-b"]
    assert b.rank_range is None  # a reference row: out of the ranks
    release(ch, phase, tmp_path / "pub", who="org", why="results day")
    page = (tmp_path / "pub" / "index.html").read_text()
    assert "<title>page-ci: open results</title>" in page
    assert 'data-team="team-b" class="muted"' in page and ">reference<" in page
    for column in ("Task Succ. %", "Model Verif. %"):  # Table IV's columns
        assert column in page, column
    assert "missing: the submission names no resource disclosure" in page
