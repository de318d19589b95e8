"""``eagc audit``: a planted agent handed the hidden truth is flagged, an honest one is not.

A local Track 1 campaign (runtime ``local``: agents as plain processes, development only)
of one challenge episode (an exception is always planned there) and two teams: the
heuristic baseline, and ``tests/orchestrator/_planted_agent.py``, to which the test hands
the hidden scenario's entities and planned exception through a file named in its
environment. The episodes run through the real worker and are committed to the results
store as a campaign run commits them; then the audit replays them, reruns one of each
team, and checks the files. The pure checks get tests of their own, on made-up inputs.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import yaml
from typer.testing import CliRunner

from orchestrator._campaign.audit import TeamAudit, audit_team, report_lines, write_report
from orchestrator._campaign.seeds import commitment, load_secret, seed_list
from orchestrator._campaign.spec import campaign_dir, load_campaign, plan, store_path
from orchestrator._episode.audit import HostSteps, log_step_findings
from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._results.store import ResultsStore
from orchestrator._runtimes.local import LocalProcessRuntime
from orchestrator.cli.main import app
from plugins import load_track
from plugins.track1.audit import Shown, Timeline, detection_flags, world_model_flags
from schemas import Limits, LogRecord, WorldModel

ROOT = Path(__file__).resolve().parents[2]
HONEST = f"python {ROOT / 'examples' / 'track1_heuristic' / 'agent.py'}"
PLANTED = f"python {ROOT / 'tests' / 'orchestrator' / '_planted_agent.py'}"
LIMITS = {"max_steps_per_stage": 120, "time_scale": 0.3, "startup_s": 60.0, "pin_cpus": False}
NAME = "audit-ci"
#: The exceptions whose subject the scenario names (a door to lock is chosen only as
#: execution starts): the planted agent names it in its early claim.
PARAMS = {"exceptions": ["object_relocation", "tool_substitution", "container_unavailable"]}


# ---------------------------------------------------------------------------- pure checks
def _shown() -> Shown:
    shown = Shown()
    shown.observe(0, {"detections": [{"id": 5, "state": "closed"}]}, {"room": [1]})
    shown.observe(3, {}, {"det_id": [7, -1], "held": [-1]})
    shown.action(4, {"primitive": 2, "target": 9}, {"ok": False, "reason": "locked"})
    shown.action(4, {"primitive": 2, "target": 11}, {"ok": False, "reason": "unknown_id"})
    shown.message(5, {"type": "queries", "data": {"queries": [{"id": "q1", "rooms": [2, 3]}]}})
    return shown


def test_world_model_flags_what_was_never_shown() -> None:
    model = WorldModel.model_validate({
        "rooms": [{"id": 1}, {"id": 4}],
        "doors": [{"id": 9, "state": "locked"}, {"id": 5, "state": "locked"}],
        "objects": [{"id": 7, "room": 2}, {"id": 11}, {"id": "13"}],
    })
    flags = world_model_flags(model, _shown(), step=10, where="final")
    got = {f.check: f.subjects for f in flags}
    assert got == {"unseen_id": ("11", "13"), "unseen_room": ("room 4",),
                   "unseen_state": ("5",)}
    assert all(f.severity == "flag" for f in flags)
    assert "objects 11, 13" in flags[0].message
    # Before step 3 id 7 had not been shown, nor rooms 2 and 3 before step 5.
    early = {f.check: f.subjects for f in world_model_flags(model, _shown(), step=2,
                                                            where="exploration")}
    assert early["unseen_id"] == ("7", "9", "11", "13")
    assert early["unseen_room"] == ("room 2", "room 4")
    assert early["unseen_state"] == ("5",)  # door 9 is unseen then: an id, not a state


def test_a_world_model_the_score_grades_is_checked_not_called_unreadable() -> None:
    """Keys nothing grades are ignored by the audit as by the score: a team's own extra
    keys do not make its model "unreadable" to the audit."""
    from plugins.track1.audit import Snapshot, check_episode

    blob = json.dumps({"rooms": ["kitchen"], "agent_state": {"pose": [0, 0, 0]},
                       "objects": [{"id": 11, "name": "red mug"}]}).encode()  # rooms: names
    flags = check_episode(_shown(), scenario_params={}, events=[],
                          snapshots=[Snapshot("final", 10, {"world_model.json": blob})], log=[])
    checks = {f.check for f in flags}
    assert "unreadable_file" not in checks and "unseen_id" in checks, flags
    broken = check_episode(_shown(), scenario_params={}, events=[],
                           snapshots=[Snapshot("final", 10, {"world_model.json": b"{"})],
                           log=[])
    assert [f.check for f in broken] == ["unreadable_file"], broken


def test_on_vision_the_models_ids_are_the_agents_own_and_only_rooms_are_checked() -> None:
    """The vision split shows no ids: a world model's ids there are the agent's own, so
    "never shown" would flag every one; the audit says so in a note and checks the rooms."""
    from plugins.track1.audit import Snapshot, check_episode

    blob = json.dumps({"rooms": [{"id": 2, "type": "kitchen"}, {"id": 4, "type": "hall"}],
                       "doors": [{"id": 1001, "state": "locked"}],
                       "objects": [{"id": 1007, "room": 2}]}).encode()
    plugin = load_track("track1")
    for split, unseen in (("vision", set()), ("standard", {"unseen_id"})):
        params = plugin.make_scenario(seed=3, split=split, params={}).params
        flags = check_episode(_shown(), scenario_params=params, events=[],
                              snapshots=[Snapshot("final", 10, {"world_model.json": blob})],
                              log=[])
        checks = {f.check for f in flags}
        assert "unseen_room" in checks, (split, flags)  # room 4 was never shown
        assert checks & {"unseen_id", "unseen_state"} == unseen, (split, flags)
        assert ("own_ids" in checks) == (split == "vision"), (split, flags)


def test_segmentation_counts_as_shown() -> None:
    import numpy as np

    shown = Shown()
    shown.observe(2, {}, {"segmentation": np.array([[-1, 42], [42, 43]])})
    assert shown.id_by(42, 2) and shown.id_by(43, 5) and not shown.id_by(42, 1)


def test_detection_flags_by_timeline() -> None:
    params = {"exception": {"type": "object_relocation", "goal": 0},
              "task": {"goals": [{"kind": "place", "object": 40, "receptacle": 3}]}}
    events = [{"event": "exception", "type": "object_relocation", "subject": 40, "step": 50},
              {"event": "exception_observable", "type": "object_relocation", "step": 60}]
    timeline = Timeline.from_log(params, events)
    assert (timeline.step, timeline.effect_step, timeline.subject) == (50, 60, 40)

    def record(step: int, kind: str, **data: Any) -> LogRecord:
        return LogRecord(step=step, event="exception_detected", exception_type=kind, data=data)

    flags = detection_flags([record(10, "object_relocation", item=40),
                             record(20, "object_relocation", item=7),
                             record(55, "object_relocation", item=40),
                             record(58, "object_relocation", item=40),
                             record(59, "object_relocation", item=40),  # one step slack
                             record(61, "object_relocation", item=40),
                             record(62, "door_lock")], timeline)
    assert [(f.step, f.check, f.severity) for f in flags] == [
        (10, "early_detection", "flag"), (20, "early_detection", "warning"),
        (55, "early_detection", "flag"), (58, "early_detection", "flag"),
        (62, "false_alarm", "note")]
    # Planned, never applied: the plan's subject still counts.
    never = Timeline.from_log(params, [])
    assert [f.severity for f in detection_flags([record(5, "object_relocation", item=40)],
                                                never)] == ["flag"]


def test_log_steps_against_the_host() -> None:
    host = HostSteps(total=100, stages={"exploration": (0, 40), "execution": (40, 100)})
    records = [LogRecord(step=3, stage="exploration", event="stage"),
               LogRecord(step=41, stage="exploration", event="note"),
               LogRecord(step=70, stage="execution", event="note"),
               LogRecord(step=500, stage="execution", event="note")]
    found = log_step_findings(records, host)
    assert [(f.severity, f.step) for f in found] == [("flag", 500)]
    far = [*records[:2], LogRecord(step=90, stage="exploration", event="note")]
    assert [(f.severity, f.step) for f in log_step_findings(far, host)] == [("warning", 90)]


# ---------------------------------------------------------------------------- a campaign
@dataclass
class Campaign:
    path: Path
    spec: Any
    truth: Path


def _truth(seed: int, split: str, index: int, folder: Path) -> Path:
    """The hidden scenario's entities and planned exception, as the planted agent reads it."""
    plugin = load_track("track1")
    scenario = plugin.make_scenario(seed=seed, split=split, params=PARAMS, index=index)
    episode: Any = plugin.make_episode(scenario)
    try:
        episode.reset()
        gt = episode.env.ground_truth()
    finally:
        episode.close()
    params = scenario.params
    exception = params.get("exception")
    goal = params["task"]["goals"][exception["goal"]] if exception else None
    subject = None
    if exception and exception["type"] == "container_unavailable":
        subject = goal["receptacle"]
    elif exception and exception["type"] != "door_lock":
        subject = goal["object"] if goal["kind"] == "place" else goal["tool"]
    path = folder / f"truth-{split}-{index}.json"
    path.write_text(json.dumps({
        "rooms": [r.id for r in gt.rooms], "doors": [d.id for d in gt.doors],
        "containers": [c.id for c in gt.containers],
        "objects": [o.id for o in gt.objects],
        "exception": None if subject is None else {"type": exception["type"],
                                                   "subject": subject}}))
    return path


@pytest.fixture(scope="module")
def campaign() -> Iterator[Campaign]:
    import shutil
    import tempfile

    folder = Path(tempfile.mkdtemp(prefix="eagc-au-", dir="/tmp"))  # short: unix sockets
    doc = {"name": NAME, "track": "track1", "phase": "local", "runtime": "local",
           "splits": [{"name": "challenge", "weight": 1.0, "episodes": 1, "params": PARAMS}],
           "submissions": [{"team": "honest", "image": HONEST},
                           {"team": "planted", "image": PLANTED}],
           "limits": LIMITS, "retries": 0, "output": str(folder / "out")}
    path = folder / "campaign.yaml"
    path.write_text(yaml.safe_dump(doc))
    spec = load_campaign(path)
    seeds = seed_list(spec, load_secret(spec))
    by_key = {(s.split, s.index): s.seed for s in seeds}
    truth = _truth(by_key[("challenge", 0)], "challenge", 0, folder)
    assert json.loads(truth.read_text())["exception"], "the challenge split plans none"
    mp = pytest.MonkeyPatch()
    mp.setenv("EAGC_PLANTED_TRUTH", str(truth))  # the local runtime passes it on
    runs = campaign_dir(spec)
    runs.mkdir(parents=True, mode=0o700)
    with ResultsStore(store_path(spec)) as store:
        keys = plan(spec)
        store.register(spec, commitment(spec, seeds), len(keys))
        images = {s.team: s.image for s in spec.submissions}
        for key in keys:
            result = run_episode(EpisodeSpec(
                track="track1", image=images[key.submission], seed=by_key[(key.split,
                                                                           key.index)],
                split=key.split, params=PARAMS, limits=spec.limits, runs_dir=runs,
                index=key.index,
                labels={"campaign": NAME, "submission": key.submission}),
                LocalProcessRuntime(quiet=True))
            assert result.status.value == "completed", (key, result.failure)
            store.commit(NAME, key, result, retry=0, node=None)
    try:
        yield Campaign(path, spec, truth)
    finally:
        mp.undo()
        shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="module")
def audits(campaign: Campaign) -> dict[str, TeamAudit]:
    return {team: audit_team(campaign.spec, team, rerun=1) for team in ("honest", "planted")}


@pytest.mark.slow
def test_the_honest_baseline_passes(audits: dict[str, TeamAudit]) -> None:
    honest = audits["honest"]
    assert honest.clean, "\n".join(report_lines(honest))
    (episode,) = honest.episodes
    assert episode.audit is not None and episode.audit.replay is not None
    assert episode.audit.replay.ok and episode.audit.replay.steps > 0
    assert not [f for f in episode.audit.findings if f.severity == "flag"]
    (rerun,) = honest.reruns
    assert rerun.rerun_status == "completed"
    assert rerun.rerun_episode != rerun.official_episode
    assert Path(rerun.folder, "host", "result.json").is_file()
    assert rerun.difference == pytest.approx(rerun.rerun - rerun.official)


@pytest.mark.slow
def test_the_planted_agent_is_flagged(audits: dict[str, TeamAudit], campaign: Campaign) -> None:
    planted = audits["planted"]
    assert not planted.clean
    (episode,) = planted.episodes
    assert episode.audit is not None and episode.audit.replay is not None
    assert episode.audit.replay.ok  # the host was right; the files were not
    flags = [f for f in episode.audit.findings if f.severity == "flag"]
    checks = {f.check for f in flags}
    assert {"unseen_id", "unseen_room", "early_detection"} <= checks, flags
    truth = json.loads(campaign.truth.read_text())
    early = next(f for f in flags if f.check == "early_detection")
    assert early.subjects == (truth["exception"]["type"],) and early.step == 1
    unseen = next(f for f in flags if f.check == "unseen_id")
    assert set(unseen.subjects) <= {str(i) for k in ("doors", "containers", "objects")
                                    for i in truth[k]}
    assert len(unseen.subjects) > len(truth["objects"]) // 2  # 12 moves show few of them


@pytest.mark.slow
def test_report_files_and_width(audits: dict[str, TeamAudit], tmp_path: Path) -> None:
    for audit in audits.values():
        text, data = write_report(audit, tmp_path)
        lines = text.read_text().splitlines()
        assert max(len(line) for line in lines) <= 80
        doc = json.loads(data.read_text())
        assert doc["clean"] == audit.clean and doc["team"] == audit.team
        assert doc["episodes"][0]["audit"]["replay"]["ok"] is True
    assert "FLAGGED" in (tmp_path / "planted.txt").read_text()
    assert "verdict: clean" in (tmp_path / "honest.txt").read_text()


@pytest.mark.slow
def test_cli_exit_codes(campaign: Campaign, tmp_path: Path) -> None:
    runner = CliRunner()
    args = ["audit", str(campaign.path), "--output", str(tmp_path)]
    clean = runner.invoke(app, [*args, "--team", "honest"])
    assert clean.exit_code == 0, clean.output
    assert (tmp_path / "honest.json").is_file()
    flagged = runner.invoke(app, [*args, "--team", "planted"])
    assert flagged.exit_code == 1, flagged.output
    unknown = runner.invoke(app, [*args, "--team", "nobody"])
    assert unknown.exit_code == 2
    assert "no team 'nobody'" in unknown.output and "Traceback" not in unknown.output
    negative = runner.invoke(app, [*args, "--team", "honest", "--rerun", "-1"])
    assert negative.exit_code == 2


def test_a_track_without_checks_gets_replay_and_log_steps() -> None:
    """The sanity track ships no audit module: replay and log steps still run, and a log
    that claims more steps than the host served is flagged."""
    import shutil
    import tempfile

    from orchestrator._episode.audit import audit_episode, track_checks

    assert track_checks("sanity") is None and track_checks("track1") is not None
    runs = Path(tempfile.mkdtemp(prefix="eagc-au-", dir="/tmp"))  # short: unix sockets
    try:
        result = run_episode(EpisodeSpec(
            track="sanity", image=f"python {ROOT / 'examples' / 'sanity_agent' / 'agent.py'}",
            seed=3, runs_dir=runs, limits=Limits(time_scale=0.2, startup_s=30.0,
                                                 pin_cpus=False)),
            LocalProcessRuntime(quiet=True))
        folder = Path(result.episode_dir)
        clean = audit_episode(folder)
        assert clean.replay is not None and clean.replay.ok and clean.host_steps > 0
        assert not clean.flagged, clean.findings
        log = folder / "host" / "output" / "episode_log.jsonl"
        log.write_text(log.read_text() + json.dumps(
            {"step": clean.host_steps + 50, "event": "note"}) + "\n")
        tampered = audit_episode(folder, verify=False)
        assert tampered.replay is None
        assert [f.check for f in tampered.findings if f.severity == "flag"] == ["log_steps"]
    finally:
        shutil.rmtree(runs, ignore_errors=True)
