"""The channel's rules on its real database, with its clock injected (no registry, no
Docker): tokens that expire and are revoked, leases that run out, infrastructure failures
that cost nothing, pre-flights that fail for the team's reason, queue positions and ETAs,
and the challenge file's times."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import pytest
from pydantic import ValidationError

from orchestrator._channel.channel import Channel, split_reference
from orchestrator._channel.db import ChannelError, Clock
from orchestrator._channel.registry import RegistryProcess
from schemas import ChallengeSpec, Outcome, Progress, SubmissionState, SubmitRequest, parse_when

S = SubmissionState
T0 = datetime(2026, 5, 1, 12, 0, tzinfo=UTC).timestamp()


def _spec(**extra: object) -> ChallengeSpec:
    doc = {"name": "rules", "track": "sanity", "teams": ["team-a", "team-b"], "lease_s": 60,
           "phases": [{"name": "open", "splits": [{"name": "standard", "episodes": 3}],
                       "retries": 1}]}
    doc.update(extra)
    return ChallengeSpec.model_validate(doc)


@pytest.fixture()
def channel(tmp_path: Path) -> Channel:
    clock = Clock(origin=T0, speed=0.0)  # frozen: the test moves it
    ch = Channel(_spec(), tmp_path / "data", clock=clock)
    ch.add_spec_teams()
    # Its address only: claims name the image to pull there (nothing is pulled here).
    ch.registry = RegistryProcess(tmp_path / "registry", ch.keys, realm="http://unused",
                                  port=5999)
    return ch


def _advance(channel: Channel, seconds: float) -> None:
    channel.clock.origin += seconds


def _submission(channel: Channel, team: str = "team-a") -> str:
    return channel.db.create(team=team, phase="open", repository=f"teams/{team}/agent",
                             digest="sha256:" + "a" * 64, note="", disclosure=None, planned=3)


def test_a_token_is_accepted_until_it_expires_or_is_replaced(channel: Channel) -> None:
    token, _ = channel.db.new_token("team-a", days=2)
    assert channel.db.check_token(token).team == "team-a"
    unknown = channel.db.check_token("eagc_not-a-token")
    assert unknown.team is None and "not one the channel issued" in unknown.problem
    _advance(channel, 2 * 86400 + 1)
    expired = channel.db.check_token(token)
    assert expired.team is None and "expired on 2026-05-03 12:00 UTC" in expired.problem
    fresh, _ = channel.db.new_token("team-a", days=2)
    revoked = channel.db.check_token(token)
    assert revoked.team is None and "revoked on 2026-05-03" in revoked.problem
    assert channel.db.check_token(fresh).team == "team-a"
    # Stored hashed: the token itself is nowhere in the database.
    assert fresh.encode() not in (channel.data / "channel.sqlite").read_bytes()


def test_a_runner_that_stops_renewing_loses_the_submission_to_the_queue(
        channel: Channel) -> None:
    sid = _submission(channel)
    work = channel.claim("r1", "preflight")
    assert work is not None and work.id == sid
    channel.report(sid, Outcome(runner="r1", kind="preflight", ok=True, reason="fine"))
    assert channel.db.get(sid).state == S.QUEUED  # type: ignore[union-attr]
    assert channel.claim("r1", "run") is not None
    _advance(channel, 40)
    channel.heartbeat(sid, Progress(runner="r1", episodes_done=1, episodes_planned=3))
    _advance(channel, 40)  # 80 s after the claim, 40 after the heartbeat: still held
    assert channel.expire_leases() == []
    _advance(channel, 21)  # 61 s without a heartbeat
    assert channel.expire_leases() == [sid]
    row = channel.db.get(sid)
    assert row is not None and row.state == S.QUEUED and row.lease_expiries == 1
    assert "lease expired" in row.reason
    # The lost runner can neither renew nor report any more; another runner takes it.
    with pytest.raises(ChannelError) as e:
        channel.heartbeat(sid, Progress(runner="r1"))
    assert e.value.status == 409
    again = channel.claim("r2", "run")
    assert again is not None and again.id == sid


def test_infrastructure_failures_wait_again_at_no_cost_then_fail_as_not_the_teams(
        channel: Channel) -> None:
    sid = _submission(channel)
    channel.claim("r", "preflight")
    channel.report(sid, Outcome(runner="r", kind="preflight", ok=True))
    channel.claim("r", "run")
    channel.report(sid, Outcome(runner="r", kind="run", ok=False, infrastructure=True,
                                reason="the engine went away"))
    row = channel.db.get(sid)
    assert row is not None and row.state == S.QUEUED and row.infra_retries == 1
    channel.claim("r", "run")
    channel.report(sid, Outcome(runner="r", kind="run", ok=False, infrastructure=True,
                                reason="the engine went away again"))
    view = channel.view(sid, team="team-a")
    assert view.state == S.FAILED
    assert view.reason.startswith("infrastructure: the engine went away again")
    assert "not the team's fault" in view.reason
    states = [h.state for h in view.history]
    assert states == [S.RECEIVED, S.PREFLIGHT, S.QUEUED, S.RUNNING, S.QUEUED, S.RUNNING,
                      S.FAILED]


def test_a_failed_preflight_ends_the_submission_with_the_check_that_failed(
        channel: Channel) -> None:
    sid = _submission(channel)
    channel.claim("r", "preflight")
    channel.report(sid, Outcome(runner="r", kind="preflight", ok=False,
                                reason="the container starts: exec format error"))
    view = channel.view(sid, team="team-a")
    assert view.state == S.FAILED
    assert view.reason == "pre-flight: the container starts: exec format error"
    assert channel.claim("r", "run") is None


def test_another_teams_submission_is_not_found_as_a_missing_one(channel: Channel) -> None:
    sid = _submission(channel, "team-a")
    with pytest.raises(ChannelError) as theirs:
        channel.view(sid, team="team-b")
    with pytest.raises(ChannelError) as missing:
        channel.view("s-0000000000", team="team-b")
    assert theirs.value.status == missing.value.status == 404
    assert str(theirs.value).replace(sid, "ID") == str(missing.value).replace(
        "s-0000000000", "ID")


def test_queue_positions_and_an_eta_from_measured_episode_durations(
        channel: Channel) -> None:
    ids = []
    for team in ("team-a", "team-b", "team-a"):
        ids.append(_submission(channel, team))
        _advance(channel, 1)
    for sid in ids:  # pre-flights in the order received, queued in the order passed
        work = channel.claim("r", "preflight")
        assert work is not None and work.id == sid
        channel.report(sid, Outcome(runner="r", kind="preflight", ok=True))
        _advance(channel, 1)
    views = [channel.view(s, team=None) for s in ids]
    assert [v.position for v in views] == [1, 2, 3]
    assert all(v.eta_s is None for v in views)  # nothing measured yet
    # One scored run of 3 episodes in 30 s: 10 s an episode.
    with channel.db.tx() as db:
        db.execute("UPDATE submissions SET state='scored', wall_s=30, queued_at=NULL "
                   "WHERE id=?", (ids[0],))
    assert channel.view(ids[1], team=None).position == 1
    assert channel.view(ids[1], team=None).eta_s == 0.0
    assert channel.view(ids[2], team=None).eta_s == pytest.approx(30.0)


def test_times_of_the_challenge_file() -> None:
    start = datetime(2026, 5, 1, tzinfo=UTC)
    assert parse_when("start", start) == start
    assert parse_when("start+90m", start) == datetime(2026, 5, 1, 1, 30, tzinfo=UTC)
    # 23:59 Anywhere on Earth (UTC-12) is 11:59 UTC the next day.
    assert parse_when("2026-06-10 AoE", start) == datetime(2026, 6, 11, 11, 59, tzinfo=UTC)
    assert parse_when("2026-06-01T00:00Z", start) == datetime(2026, 6, 1, tzinfo=UTC)
    with pytest.raises(ValidationError, match="no time zone"):
        _spec(phases=[{"name": "x", "closes": "2026-06-01T00:00",
                       "splits": [{"name": "standard", "episodes": 1}]}])
    with pytest.raises(ValidationError, match="team 'Team A'"):
        _spec(teams=["Team A"])


def test_a_closed_phase_names_the_next_window(tmp_path: Path) -> None:
    spec = _spec(phases=[{"name": "later", "opens": "start+2h",
                          "splits": [{"name": "standard", "episodes": 1}]}])
    ch = Channel(spec, tmp_path / "d", clock=Clock(origin=T0, speed=0.0))
    with pytest.raises(ChannelError, match="phase later opens 2026-05-01 14:00 UTC"):
        ch.open_phase()
    ch.clock.origin += 2 * 3600
    assert ch.open_phase().name == "later"


def test_image_references() -> None:
    assert split_reference("teams/a/x@sha256:ab") == ("teams/a/x", "sha256:ab")
    assert split_reference("teams/a/x:v2") == ("teams/a/x", "v2")
    assert split_reference("teams/a/x") == ("teams/a/x", "latest")
    assert split_reference("127.0.0.1:5000/teams/a/x") == ("127.0.0.1:5000/teams/a/x",
                                                          "latest")


def _accept(channel: Channel, team: str = "team-a") -> str:
    return channel.accept(team, channel.open_phase(), f"teams/{team}/agent",
                          "sha256:" + "b" * 64, SubmitRequest(image="x")).id


def _quota_channel(tmp_path: Path, **quota: int) -> Channel:
    spec = _spec(phases=[{"name": "open", "quota": quota, "retries": 0,
                          "splits": [{"name": "standard", "episodes": 1}]}])
    ch = Channel(spec, tmp_path / "q", clock=Clock(origin=T0, speed=0.0))
    ch.add_spec_teams()
    ch.registry = RegistryProcess(tmp_path / "reg", ch.keys, realm="http://unused", port=5999)
    return ch


def _finish(ch: Channel, sid: str, **outcome: object) -> None:
    work = ch.claim("r", "preflight")
    assert work is not None and work.id == sid
    ch.report(sid, Outcome(runner="r", kind="preflight", **outcome))  # type: ignore[arg-type]


def test_the_days_quota_refuses_with_its_reset_time_and_refunds_what_was_not_the_team(
        tmp_path: Path) -> None:
    ch = _quota_channel(tmp_path, per_day=2, concurrent=5)
    first = _accept(ch)
    _finish(ch, first, ok=True)
    ch.claim("r", "run")
    ch.report(first, Outcome(runner="r", kind="run", ok=False, infrastructure=True,
                             reason="the node died"))  # retries 0: failed, refunded
    assert not ch.db.get(first).charged  # type: ignore[union-attr]
    second = _accept(ch)
    _finish(ch, second, ok=False, reason="the container starts: no such file")
    assert "refunded" in ch.view(second, team="team-a").history[-1].detail
    _accept(ch)
    _accept(ch)  # two charged now: the refunds gave two back
    q = ch.quota("team-a")
    assert (q.used, q.left, q.refunded, q.failed_preflights) == (2, 0, 2, 1)
    with pytest.raises(ChannelError) as e:
        _accept(ch)
    assert e.value.status == 429
    assert "your 2 submissions of 2026-05-01 (UTC)" in str(e.value)
    assert "accepted from 2026-05-02 00:00 UTC (in 12 h 0 min)" in str(e.value)
    assert ch.quota("team-b").left == 2  # per team
    ch.grant("team-a", 1, who="org", why="our registry was down an hour")
    _accept(ch)
    _advance(ch, 12 * 3600)  # the next UTC day
    assert ch.quota("team-a").left == 2


def test_concurrency_and_a_teams_own_cancel_frees_its_slot_at_once(tmp_path: Path) -> None:
    ch = _quota_channel(tmp_path, per_day=10, concurrent=1)
    sid = _accept(ch)
    with pytest.raises(ChannelError, match="1 of your submissions wait or run"):
        _accept(ch)
    with pytest.raises(ChannelError) as theirs:
        ch.cancel(sid, team="team-b")
    assert theirs.value.status == 404
    ch.cancel(sid, team="team-a")
    assert ch.view(sid, team="team-a").state == S.CANCELLED
    assert ch.db.get(sid).charged  # type: ignore[union-attr]  # the team's own choice
    _accept(ch)


def test_failed_preflights_are_capped_a_day(tmp_path: Path) -> None:
    ch = _quota_channel(tmp_path, per_day=10, failed_preflights_per_day=2)
    for _ in range(2):
        _finish(ch, _accept(ch), ok=False, reason="bad")
    with pytest.raises(ChannelError, match="2 failed pre-flights today"):
        _accept(ch)


def test_the_organizers_hand_is_recorded_with_who_when_and_why(tmp_path: Path) -> None:
    ch = _quota_channel(tmp_path, per_day=10, concurrent=10)
    a, b = _accept(ch), _accept(ch, "team-b")
    _advance(ch, 1)  # the rerun below comes after b
    ch.cancel(a, team=None, who="alice", why="wrong phase")
    assert not ch.db.get(a).charged  # type: ignore[union-attr]
    assert "cancelled by the organizers (alice): wrong phase" in ch.view(
        a, team="team-a").history[-1].detail
    again = ch.rerun(a, who="alice", why="the node was bad")
    rerun = ch.view(again, team="team-a")
    assert rerun.state == S.RECEIVED and not rerun.charged
    assert f"rerun by the organizers (alice) as {again}" in ch.view(
        a, team="team-a").history[-1].detail
    ch.pause(True, who="bob", why="registry maintenance")
    with pytest.raises(ChannelError, match="paused the channel: registry maintenance"):
        _accept(ch)
    assert ch.claim("r", "preflight") is None  # no work handed out while paused
    ch.pause(False, who="bob", why="done")
    ch.disable("team-b", True, who="bob", why="shared a token")
    token, _ = ch.db.new_token("team-b", 1)
    assert "disabled" in ch.db.check_token(token).problem
    _finish(ch, b, ok=True)
    with ch.db.tx() as db:  # its run scored (what an incident's window may refund)
        db.execute("UPDATE submissions SET state='scored' WHERE id=?", (b,))
    refunded = ch.refund_window(T0 - 1, T0 + 10, who="carol", why="the engine crashed")
    assert refunded == [b]
    assert [(w, act) for _, w, act, _, _ in ch.db.actions()] == [
        ("alice", "cancel"), ("alice", "rerun"), ("bob", "pause"), ("bob", "resume"),
        ("bob", "disable"), ("carol", "refund")]


def _phase_channel(tmp_path: Path, **phase: object) -> Channel:
    doc = {"name": "open", "closes": "start+1d", "quota": {"per_day": 10, "concurrent": 10},
           "splits": [{"name": "standard", "episodes": 2}]}
    doc.update(phase)
    ch = Channel(_spec(phases=[doc]), tmp_path / "p", clock=Clock(origin=T0, speed=0.0))
    ch.add_spec_teams()
    ch.registry = RegistryProcess(tmp_path / "reg", ch.keys, realm="http://unused", port=5999)
    return ch


def _scored(ch: Channel, sid: str, final: float) -> None:
    with ch.db.tx() as db:  # as a run's report leaves it (the board's rows are its store's)
        db.execute("UPDATE submissions SET state='scored', result=?, updated_at=? "
                   "WHERE id=?", (f'{{"final": {final}}}', ch.clock.now(), sid))
    _advance(ch, 1)


def test_a_finalists_phase_admits_its_finalists_only(tmp_path: Path) -> None:
    ch = _phase_channel(tmp_path, who="finalists", kind="final")
    with pytest.raises(ChannelError, match="admits its finalists only"):
        _accept(ch)
    ch.set_finalists(ch.open_phase(), ["team-a"], who="org", why="ranks 1-2 <= K")
    _accept(ch)
    with pytest.raises(ChannelError) as e:
        _accept(ch, "team-b")
    assert e.value.status == 403
    assert ch.db.actions()[-1][2:] == ("finalists", "open", "team-a: ranks 1-2 <= K")


def test_which_submission_the_board_counts(tmp_path: Path) -> None:
    latest = _phase_channel(tmp_path / "l")
    a1, a2 = _accept(latest), _accept(latest)
    _scored(latest, a1, 80.0)
    _scored(latest, a2, 40.0)
    assert latest.counted(latest.open_phase())["team-a"].id == a2
    with pytest.raises(ChannelError, match="nothing to select"):
        latest.select(a1, "team-a")

    chosen = _phase_channel(tmp_path / "s", counts="selected")
    s1, s2 = _accept(chosen), _accept(chosen)
    _scored(chosen, s1, 80.0)
    _scored(chosen, s2, 40.0)
    assert chosen.counted(chosen.open_phase())["team-a"].id == s2  # none chosen: latest
    chosen.select(s1, "team-a")
    assert chosen.counted(chosen.open_phase())["team-a"].id == s1
    with pytest.raises(ChannelError) as theirs:
        chosen.select(s1, "team-b")
    assert theirs.value.status == 404
    _advance(chosen, 86400)  # the deadline has passed: the choice stands
    with pytest.raises(ChannelError, match="closed: its selection is final"):
        chosen.select(s2, "team-a")

    with pytest.raises(ValidationError, match="luckiest draw on hidden seeds"):
        _spec(phases=[{"name": "x", "counts": "best",
                       "splits": [{"name": "standard", "episodes": 1}]}])
    best = _phase_channel(tmp_path / "b", counts="best", public_splits=["standard"])
    b1, b2 = _accept(best), _accept(best)
    _scored(best, b1, 80.0)
    _scored(best, b2, 40.0)
    assert best.counted(best.open_phase())["team-a"].id == b1


def test_seeds_are_committed_before_and_revealed_after_a_phase(tmp_path: Path) -> None:
    import hashlib

    ch = _phase_channel(tmp_path)
    commitment, text = ch.seeds(ch.open_phase())
    assert hashlib.sha256(text.encode()).hexdigest() == commitment
    assert text.splitlines()[0].startswith("rules-open/standard/0 ")
    with pytest.raises(ChannelError, match="its seeds are revealed after"):
        ch.reveal(ch.open_phase())
    _advance(ch, 86400)
    assert ch.reveal(ch.phase("open")) == text
    ch.check_seeds_apart()  # one phase: nothing shared


def test_two_phases_never_share_a_seed(tmp_path: Path) -> None:
    """Even with one secret for both, two phases draw different seeds (the campaign's name
    is part of every seed), and the channel checks it when it starts."""
    secret = tmp_path / "one.secret"
    secret.write_text("the same secret for both\n")
    secret.chmod(0o600)
    phases = [{"name": n, "secret": f"file:{secret}",
               "splits": [{"name": "standard", "episodes": 200}]} for n in ("qual", "final")]
    ch = Channel(_spec(phases=phases), tmp_path / "d", clock=Clock(origin=T0, speed=0.0))
    qual, final = (set(ch.seeds(p)[1].split()[1::2]) for p in ch.spec.phases)
    assert len(qual) == len(final) == 200 and not qual & final
    ch.check_seeds_apart()
