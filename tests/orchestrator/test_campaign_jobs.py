"""A campaign's job carries its episode's ``EpisodeSpec``, built once by the driver.

The job crosses Ray pickled; the worker runs the spec it carries (the pinned image ID
swapped in on its node). One real campaign on an embedded Ray, with the sanity baseline as
local processes: every episode runs with the seed, split and index the plan gave it, in the
campaign's folder, and its worker's start report reaches ``events.jsonl``.
"""

from __future__ import annotations

import json
import os
import pickle
from pathlib import Path

import yaml
from mcap.reader import make_reader
from test_campaign_helpers import short_dir, write_campaign

from orchestrator._campaign.driver import run_campaign
from orchestrator._campaign.driver_io import CampaignOptions
from orchestrator._campaign.fanout import EpisodeJob, campaign_labels
from orchestrator._campaign.seeds import load_secret, seed_list
from orchestrator._campaign.spec import load_campaign
from orchestrator._episode.worker import EpisodeSpec
from orchestrator._results.store import EpisodeKey, ResultsStore
from schemas import EpisodeWhere, Limits

REPO = Path(__file__).resolve().parents[2]
AGENT = REPO / "examples" / "sanity_agent" / "agent.py"


def _job() -> EpisodeJob:
    spec = EpisodeSpec(track="sanity", image="python agent.py", seed=123456789,
                       split="challenge", params={"obstacles": 3},
                       limits=Limits(cpus=2.0, memory_mb=512), runs_dir=Path("/tmp/c1"),
                       labels=campaign_labels("c1", "team-a", 2), episode="ep-1", index=4)
    return EpisodeJob(campaign="c1", submission="team-a", retry=2, spec=spec,
                      digest=None, runtime="local", code="abc")


def test_the_job_names_its_episode_from_its_spec() -> None:
    job = _job()
    assert job.episode == "ep-1"
    assert job.key == EpisodeKey("team-a", "challenge", 4)
    assert job.where == EpisodeWhere(submission="team-a", split="challenge", index=4,
                                     retry=2, episode="ep-1")
    assert job.spec.labels == {"campaign": "c1", "submission": "team-a", "retry": "2"}


def test_the_job_crosses_a_pickle_whole() -> None:
    import ray.cloudpickle

    job = _job()
    for dumps, loads in ((pickle.dumps, pickle.loads),
                         (ray.cloudpickle.dumps, ray.cloudpickle.loads)):
        back = loads(dumps(job))
        assert back == job
        assert back.spec.seed == 123456789 and back.spec.limits.cpus == 2.0
        assert back.spec.runs_dir == Path("/tmp/c1") and back.spec.params == {"obstacles": 3}


def test_a_campaign_runs_each_episode_as_planned() -> None:
    folder = short_dir("eagc-jobs-")
    name = "jobs-" + os.urandom(3).hex()
    path = write_campaign(folder, name, {"base": f"python {AGENT}"}, standard=1,
                          challenge=1, retries=0)
    doc = yaml.safe_load(path.read_text())
    path.write_text(yaml.safe_dump({**doc, "runtime": "local"}))
    spec = load_campaign(path)
    report = run_campaign(spec, CampaignOptions(workers=1, progress=False))
    assert report.committed == 2 and report.quarantined == 0, report

    seeds = {(s.split, s.index): s.seed for s in seed_list(spec, load_secret(spec))}
    campaign = folder / "out" / name
    with ResultsStore(folder / "out" / "results.sqlite") as store:
        stored = store.results(name)
    assert {(s.key.split, s.key.index) for s in stored} == set(seeds)
    for s in stored:
        result = s.result
        assert result.status.value == "completed", result.failure
        assert result.split == s.key.split and result.image == f"python {AGENT}"
        assert Path(result.episode_dir or "") == campaign / result.episode
        with Path(result.mcap or "").open("rb") as f:
            _, _, message = next(make_reader(f).iter_messages(topics=["/eagc/scenario"]))
        scenario = json.loads(message.data)
        assert scenario["seed"] == seeds[(s.key.split, s.key.index)]
        assert scenario["split"] == s.key.split

    events = [json.loads(line) for line in (campaign / "events.jsonl").read_text().splitlines()]
    started = [e for e in events if e.get("event") == "started"]
    assert {(e["split"], e["index"]) for e in started} == set(seeds), events
    for e in started:
        assert e["submission"] == "base" and e["retry"] == 0
        assert e["node"] and e["host"] and e["pid"] > 0, e
    assert {e["episode"] for e in started} == {s.result.episode for s in stored}
