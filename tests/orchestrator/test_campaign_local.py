"""A campaign on a local Ray with real containers, watched by a real Prometheus.

Three submissions (the sanity baseline, an agent that crashes, one that runs out of memory)
× four episodes on an embedded Ray with two container slots: the leaderboard ranks them,
reports the failures as a team may see them, and the driver's metrics reach Prometheus,
where every query of deploy/'s dashboard and alert rules evaluates.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import docker
import pytest
from prometheus_client.parser import text_string_to_metric_families
from test_campaign_helpers import (
    Prometheus,
    build_campaign_images,
    free_port,
    short_dir,
    write_campaign,
)
from typer.testing import CliRunner

from orchestrator._campaign.driver import run_campaign
from orchestrator._campaign.driver_io import CampaignOptions
from orchestrator._campaign.metrics import CampaignMetrics
from orchestrator._campaign.seeds import load_secret, seed_list
from orchestrator._campaign.spec import load_campaign, store_path
from orchestrator._results.leaderboard import build_leaderboard
from orchestrator._results.store import ResultsStore
from orchestrator.cli.campaign import campaign_app
from schemas import EpisodeStatus

pytestmark = [pytest.mark.docker, pytest.mark.slow]

DEPLOY = Path(__file__).resolve().parents[2] / "deploy"
TEAMS = {"baseline": "eagc/sanity-agent:latest", "crashy": "eagc-test/crash:latest",
         "hungry": "eagc-test/oom:latest"}


@dataclass
class Run:
    path: Path
    spec: Any
    report: Any
    prometheus: Prometheus


@pytest.fixture(scope="module")
def run(docker_engine: Any) -> Iterator[Run]:
    build_campaign_images(docker_engine, "crash", "oom")
    folder = short_dir("eagc-cl-")
    # A name of its own: the engine and Prometheus are shared with other runs.
    path = write_campaign(folder, "local-ci-" + os.urandom(3).hex(), TEAMS)
    spec = load_campaign(path)
    port = free_port()
    prom = Prometheus(folder, [f"127.0.0.1:{port}"], [DEPLOY / "prometheus" / "alerts.yml"])
    try:
        report = run_campaign(spec, CampaignOptions(workers=2, metrics_port=port,
                                                    metrics_addr="127.0.0.1",
                                                    metrics_linger_s=3.0, progress=False))
        yield Run(path, spec, report, prom)
    finally:
        prom.stop()


def test_every_episode_committed_once(run: Run) -> None:
    assert run.report.planned == 12 and run.report.committed == 12
    assert run.report.retries == 0 and run.report.quarantined == 0
    with ResultsStore(store_path(run.spec)) as store:
        stored = store.results(run.spec.name)
    assert len({(e.key, e.result.episode) for e in stored}) == 12
    left = docker.from_env().containers.list(
        all=True, filters={"label": f"eagc.campaign={run.spec.name}"})
    assert left == [], "containers of the campaign are left behind"


def test_leaderboard_order_and_failure_reports(run: Run) -> None:
    with ResultsStore(store_path(run.spec)) as store:
        board = build_leaderboard(run.spec, store)
    rows = {r.team: r for r in board.rows}
    assert board.rows[0].team == "baseline" and board.rows[0].rank == 1
    finals = [r.values["final"] for r in board.rows]
    assert finals == sorted(finals, reverse=True)
    assert rows["baseline"].values["final"] > 50 > rows["crashy"].values["final"]
    assert all(r.state == "final" and r.episodes == 4 for r in board.rows)
    # Eq. (2): 0.6 standard + 0.4 challenge.
    b = rows["baseline"].values
    assert b["final"] == pytest.approx(0.6 * b["standard"] + 0.4 * b["challenge"])

    by_team: dict[str, list[Any]] = {}
    for f in board.failures:
        by_team.setdefault(f.team, []).append(f)
    assert "baseline" not in by_team
    assert len(by_team["crashy"]) == 4 and len(by_team["hungry"]) == 4
    crash = by_team["crashy"][0]
    assert crash.status == "agent_crash" and crash.exit_code == 3 and not crash.oom_killed
    assert crash.stage_reached == "explore"
    oom = by_team["hungry"][0]
    assert oom.status == "agent_oom" and oom.oom_killed and "512 MiB" in (oom.limit_hit or "")

    # What a team may see: no seed, no scenario, no organizer path.
    text = board.to_json() + board.to_markdown() + board.to_csv() + board.render("table")
    secret = load_secret(run.spec)
    for s in seed_list(run.spec, secret):
        assert str(s.seed) not in text
    assert "/tmp/eagc-cl-" not in text and "target" not in text.lower()


def test_formats_and_cli(run: Run) -> None:
    cli = CliRunner()
    res = cli.invoke(campaign_app, ["leaderboard", str(run.path), "--format", "json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert [r["team"] for r in doc["rows"]][0] == "baseline"
    assert {c["key"] for c in doc["columns"]} >= {"standard", "challenge", "final"}
    res = cli.invoke(campaign_app, ["leaderboard", str(run.path), "--format", "csv"])
    assert res.stdout.splitlines()[0].startswith(
        "rank,rank_best,rank_worst,team,state,episodes,standard,challenge,final")
    res = cli.invoke(campaign_app, ["leaderboard", str(run.path), "--format", "md"])
    assert "| 1 | baseline |" in res.stdout and "### Failed episodes" in res.stdout
    res = cli.invoke(campaign_app, ["status", str(run.path)])
    assert res.exit_code == 0 and re.search(r"missing\s*│\s*0", res.stdout), res.stdout
    res = cli.invoke(campaign_app, ["reveal", str(run.path)])
    assert res.exit_code == 0, res.output  # the seeds match the commitment in the store


def test_seeds_never_reach_what_a_container_sees(run: Run) -> None:
    seeds = [str(s.seed).encode() for s in seed_list(run.spec, load_secret(run.spec))]
    folder = run.spec.output.resolve() / run.spec.name
    visible = [p for ep in folder.glob("ep*") for sub in ("output", "input", "sock")
               for p in (ep / sub).rglob("*") if p.is_file()]
    visible += [store_path(run.spec), folder / "events.jsonl"]
    for path in visible:
        blob = path.read_bytes()
        assert not any(s in blob for s in seeds), f"a seed is in {path}"


def test_restart_runs_nothing_more(run: Run, monkeypatch: pytest.MonkeyPatch) -> None:
    import ray

    def no_ray(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("Ray was started for a campaign with nothing left to run")

    monkeypatch.setattr(ray, "init", no_ray)
    again = run_campaign(run.spec, CampaignOptions(workers=2, progress=False))
    assert again.committed == 0 and again.skipped == 12


# ---------------------------------------------------------------------------- metrics
def test_prometheus_scraped_the_episode_counts(run: Run) -> None:
    res = run.prometheus.query(
        f'sum by (status) (last_over_time(eagc_episodes_total{{campaign="{run.spec.name}"}}[10m]))')
    assert res["status"] == "success", res
    got = {r["metric"]["status"]: float(r["value"][1]) for r in res["data"]["result"]}
    assert {k: v for k, v in got.items() if v} == {"completed": 4.0, "agent_crash": 4.0,
                                                    "agent_oom": 4.0}
    # Every status's series exists from the start, at 0 (issue 13 §10).
    assert set(got) == {s.value for s in EpisodeStatus}
    res = run.prometheus.query(
        f'last_over_time(eagc_campaign_episodes{{campaign="{run.spec.name}",state="done"}}[10m])')
    assert float(res["data"]["result"][0]["value"][1]) == 12.0


def test_promtool_accepts_the_exposition(run: Run, tmp_path: Path) -> None:
    metrics = CampaignMetrics(run.spec.name, track="sanity", phase="local")
    metrics.start_series(run.spec)  # every series at 0 first, as the driver does
    with ResultsStore(store_path(run.spec)) as store:
        for e in store.results(run.spec.name):
            metrics.episode_finished(e.key.submission, e.result)
    metrics.episode_retried("crashy")
    metrics.episode_quarantined("crashy")
    metrics.set_states({"planned": 12, "done": 12})
    text = metrics.exposition()
    # The counts by team, split and status: exactly what the store holds (2 + 2 episodes
    # per team), every other series present and at 0.
    finished = {(s.labels["submission"], s.labels["split"], s.labels["status"]): s.value
                for family in text_string_to_metric_families(text.decode())
                for s in family.samples if s.name == "eagc_episodes_total"}
    assert all(s.labels["campaign"] == run.spec.name
               for family in text_string_to_metric_families(text.decode())
               for s in family.samples if s.name == "eagc_episodes_total")
    assert {k: v for k, v in finished.items() if v} == {
        (team, split, status): 2.0 for team, status in (("baseline", "completed"),
                                                        ("crashy", "agent_crash"),
                                                        ("hungry", "agent_oom"))
        for split in ("standard", "challenge")}
    assert len(finished) == 3 * 2 * len(EpisodeStatus)
    r = subprocess.run(["promtool", "check", "metrics"], input=text, capture_output=True)
    assert r.returncode == 0, r.stdout + r.stderr


def _dashboard_queries() -> list[str]:
    doc = json.loads((DEPLOY / "grafana" / "dashboards" / "eagc.json").read_text())
    exprs = [t["expr"] for p in doc["panels"] for t in p.get("targets", [])]
    exprs += [v["query"]["query"] for v in doc["templating"]["list"] if v["type"] == "query"]
    return exprs


def test_dashboard_and_alert_queries_evaluate(run: Run) -> None:
    import yaml

    rules = yaml.safe_load((DEPLOY / "prometheus" / "alerts.yml").read_text())
    alert_exprs = [r["expr"] for g in rules["groups"] for r in g["rules"]]
    dash = _dashboard_queries()
    assert len(dash) >= 10 and len(alert_exprs) >= 3
    for expr in dash + alert_exprs:
        if expr.startswith("label_values("):  # a Grafana function: check its metric exists
            metric = expr[len("label_values("):].split(",")[0]
            expr = f"count by (campaign) (last_over_time({metric}[10m]))"
        q = (expr.replace("$campaign", run.spec.name).replace("$__rate_interval", "1m")
             .replace("${datasource}", ""))
        res = run.prometheus.query(q)
        assert res["status"] == "success", (expr, res)
    # The rules are loaded and evaluated without error.
    deadline = time.time() + 10
    while True:
        groups = run.prometheus.api("rules")["data"]["groups"]
        loaded = [r for g in groups for r in g["rules"]]
        if len(loaded) == len(alert_exprs) and all(r.get("lastEvaluation", "").startswith("2")
                                                   and not r["lastEvaluation"].startswith("0001")
                                                   for r in loaded):
            break
        assert time.time() < deadline, loaded
        time.sleep(0.5)
    assert all(r["health"] == "ok" for r in loaded), [(r["name"], r.get("lastError"))
                                                      for r in loaded]
