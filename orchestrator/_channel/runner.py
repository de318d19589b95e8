"""The runner: a client of the channel that takes submissions and runs them.

It claims work over the channel's API (as EvalAI's remote workers do), so it can run on a
Ray head elsewhere (``--address``). Two kinds of work, on separate capacity so that a
pre-flight never waits for a campaign nor takes its workers:

- **pre-flight** (a thread, one at a time): pulls ``repo@sha256:…`` with the runner's
  credentials, checks the image's size and platform, and plays one public episode in the
  sandbox (``orchestrator._channel.preflight``, a process of its own) against the
  container contract;
- **run** (the main thread): plays the phase's campaign with this one submission
  (``run_campaign``: the phase's seeds, so every submission of the phase is paired), then
  reports every episode's result; the channel scores it.

While it works it renews the submission's lease every third of its length; should the
runner die, the lease runs out and the channel puts the submission back in line. A failure
of the platform's (a pull that fails, the engine, the cluster, an episode quarantined after
its retries) is reported as ``infrastructure``: the team is not charged and the submission
waits again.
"""

from __future__ import annotations

import _thread
import json
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from orchestrator._channel.client import ChannelClient
from orchestrator._channel.db import ChannelError
from orchestrator._channel.registry import RUNNER, die_with_parent
from schemas import (
    CampaignSpec,
    EpisodeRow,
    Outcome,
    Preflight,
    Progress,
    Submission,
    Work,
)

log = logging.getLogger("eagc.runner")
Say = Callable[[str], None]


@dataclass
class Runner:
    url: str
    token: str
    runs: Path
    name: str = field(default_factory=lambda: f"runner-{os.uname().nodename}-{os.getpid()}")
    address: str | None = None
    workers: int = 1
    poll_s: float = 1.0
    say: Say = print

    def __post_init__(self) -> None:
        self.client = ChannelClient(self.url, self.token)
        self.stop = threading.Event()

    # ------------------------------------------------------------------ loops
    def serve(self) -> None:
        """Runs pre-flights on a thread and runs on this one until ``stop`` is set."""
        pre = threading.Thread(target=self._loop, args=("preflight",), daemon=True,
                               name="eagc-preflight")
        pre.start()
        try:
            self._loop("run")
        finally:
            self.stop.set()
            pre.join(timeout=5)

    def _loop(self, kind: str) -> None:
        while not self.stop.is_set():
            try:
                work = self.claim(kind)
            except ChannelError as e:
                log.warning("claiming %s work: %s", kind, e)
                self.stop.wait(self.poll_s * 5)
                continue
            if work is None:
                self.stop.wait(self.poll_s)
                continue
            self.handle(work)

    def claim(self, kind: str) -> Work | None:
        doc = self.client.call("POST", "/api/v1/runner/claim",
                               {"runner": self.name, "kind": kind})
        return None if doc is None else Work.model_validate(doc)

    def handle(self, work: Work) -> None:
        """One pre-flight or run, under a renewed lease, reported once."""
        beat = _Heartbeat(self, work)
        beat.start()
        started = time.monotonic()
        try:
            if work.kind == "preflight":
                outcome = self.preflight(work)
            else:
                outcome = self.run(work, beat)
        except KeyboardInterrupt:
            if not beat.lost.is_set():
                raise
            self.say(f"{work.id} ({work.team}): {work.kind} stopped: the submission was "
                     "cancelled or its lease taken back")
            return
        except Exception as e:  # noqa: BLE001 - anything here is the platform's failure
            log.exception("%s of %s", work.kind, work.id)
            outcome = Outcome(runner=self.name, kind=work.kind, ok=False, infrastructure=True,
                              reason=f"{type(e).__name__}: {e}"[:500])
        finally:
            beat.stop()
        if beat.lost.is_set():
            self.say(f"{work.id} ({work.team}): its lease was taken back (cancelled, or it "
                     "went back in line); the outcome is not reported")
            return
        outcome = outcome.model_copy(update={"wall_s": time.monotonic() - started})
        try:
            self.client.call("POST", f"/api/v1/runner/{work.id}/report",
                             outcome.model_dump(mode="json"))
            verdict = ("infrastructure failure" if outcome.infrastructure
                       else "ok" if outcome.ok else "failed")
            self.say(f"{work.id} ({work.team}): {work.kind} {verdict}"
                     f"{': ' + outcome.reason if outcome.reason else ''}")
        except ChannelError as e:
            self.say(f"{work.id}: the channel refused the report: {e}")

    # ------------------------------------------------------------------ the work
    def pull(self, work: Work) -> Any:
        """The submission's image, pulled by its digest; its local image object."""
        import docker

        client = docker.from_env()
        try:
            return client.images.pull(work.image, auth_config={"username": RUNNER,
                                                               "password": self.token})
        except docker.errors.DockerException as e:
            raise RuntimeError(f"pulling {work.image}: {e}") from None

    def preflight(self, work: Work) -> Outcome:
        campaign = self.campaign(work.phase)
        check: Preflight = self.phase_preflight(work.phase)
        image = self.pull(work)
        size_mb = (image.attrs.get("Size") or 0) / 2**20
        platform = f"{image.attrs.get('Os')}/{image.attrs.get('Architecture')}"
        fail = None
        if size_mb > check.max_image_mb:
            fail = (f"the image is {size_mb:,.0f} MB, over the phase's "
                    f"{check.max_image_mb:,} MB")
        elif platform not in check.platforms:
            fail = f"the image's platform is {platform}; allowed: {', '.join(check.platforms)}"
        if fail:
            return Outcome(runner=self.name, kind="preflight", ok=False, reason=fail,
                           image_id=image.id)
        split = check.split or _public_split(campaign.track)
        cmd = [sys.executable, "-m", "orchestrator._channel.preflight", "--image", image.id,
               "--track", campaign.track, "--split", split, "--seed", str(check.seed),
               "--time-scale", str(check.time_scale), "--memory-mb", str(check.memory_mb),
               "--runs", str(self.runs / "preflight")]
        if check.max_steps_per_stage:
            cmd += ["--max-steps", str(check.max_steps_per_stage)]
        self.say(f"{work.id} ({work.team}): pre-flight on {split}, seed {check.seed}")
        try:
            done = subprocess.run(cmd, capture_output=True, text=True,
                                  timeout=check.timeout_s,
                                  preexec_fn=die_with_parent(signal.SIGTERM))
        except subprocess.TimeoutExpired:
            return Outcome(runner=self.name, kind="preflight", ok=False, image_id=image.id,
                           reason=f"the pre-flight episode took over {check.timeout_s:.0f} s")
        lines = [ln for ln in done.stdout.splitlines() if ln.startswith("{")]
        if done.returncode != 0 or not lines:
            tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
            raise RuntimeError(f"the pre-flight program failed ({done.returncode}): {tail}")
        got = json.loads(lines[-1])
        return Outcome(runner=self.name, kind="preflight", ok=bool(got["ok"]),
                       infrastructure=bool(got["infrastructure"]), reason=got["summary"],
                       image_id=image.id)

    def campaign(self, phase: str) -> CampaignSpec:
        return CampaignSpec.model_validate(
            self.client.call("GET", f"/api/v1/runner/campaign/{phase}"))

    def phase_preflight(self, phase: str) -> Preflight:
        return Preflight.model_validate(
            self.client.call("GET", f"/api/v1/runner/preflight/{phase}"))

    def run(self, work: Work, beat: _Heartbeat) -> Outcome:
        from orchestrator._campaign.driver import run_campaign
        from orchestrator._campaign.driver_io import CampaignOptions, DriverFailure
        from orchestrator._results.store import ResultsStore

        image = self.pull(work)
        base = self.campaign(work.phase)
        archive = None
        if self.address:  # other nodes get the image from the driver, by its pinned ID
            archive = self.runs.resolve() / "images" / f"{work.id}.tar"
            if not archive.is_file():
                archive.parent.mkdir(parents=True, exist_ok=True)
                with archive.open("wb") as f:
                    for chunk in image.save(named=False):
                        f.write(chunk)
        spec = base.model_copy(update={
            "output": self.runs.resolve(),
            "submissions": (Submission(team=work.id, image=work.image, digest=image.id,
                                       archive=archive),)})
        beat.image_id = image.id
        beat.planned = sum(s.episodes for s in spec.splits)
        beat.store = self.runs.resolve() / "results.sqlite"
        self.say(f"{work.id} ({work.team}): running {beat.planned} episodes of "
                 f"{spec.name}")
        try:
            report = run_campaign(spec, CampaignOptions(address=self.address,
                                                        workers=self.workers, progress=False))
        except DriverFailure as e:
            return Outcome(runner=self.name, kind="run", ok=False, infrastructure=True,
                           reason=str(e).splitlines()[0], image_id=image.id)
        with ResultsStore(self.runs.resolve() / "results.sqlite") as store:
            rows = [e for e in store.results(spec.name) if e.key.submission == work.id]
            held = [q for q in store.quarantined(spec.name) if q.key.submission == work.id]
        if report.cancelled:
            return Outcome(runner=self.name, kind="run", ok=False, infrastructure=True,
                           reason="the runner was stopped during the run", image_id=image.id)
        if held or len(rows) < beat.planned:
            return Outcome(runner=self.name, kind="run", ok=False, infrastructure=True,
                           reason=f"{len(held)} episode(s) held back after infrastructure "
                           f"failures, {beat.planned - len(rows)} without a result",
                           image_id=image.id)
        return Outcome(runner=self.name, kind="run", ok=True, image_id=image.id,
                       results=tuple(EpisodeRow(split=e.key.split, index=e.key.index,
                                                result=e.result) for e in rows))


def _public_split(track: str) -> str:
    from plugins import load_track

    plugin = load_track(track)
    names = plugin.split_names()
    return "dev" if "dev" in names else names[0]


class _Heartbeat:
    """Renews a submission's lease every third of it, with the episodes done so far."""

    def __init__(self, runner: Runner, work: Work) -> None:
        self.runner, self.work = runner, work
        self.image_id: str | None = None
        self.planned = 0
        self.store: Path | None = None
        self.lost = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name="eagc-heartbeat")

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)

    def done(self) -> int:
        if self.store is None or not self.store.is_file():
            return 0
        import sqlite3

        try:
            with sqlite3.connect(f"file:{self.store}?mode=ro", uri=True, timeout=5) as db:
                row = db.execute("SELECT COUNT(*) FROM episodes WHERE submission=?",
                                 (self.work.id,)).fetchone()
            return int(row[0])
        except sqlite3.Error:
            return 0

    def _run(self) -> None:
        every = max(self.work.lease_s / 3, 1.0)
        while not self._stop.wait(every):
            try:
                self.runner.client.call(
                    "POST", f"/api/v1/runner/{self.work.id}/heartbeat",
                    Progress(runner=self.runner.name, episodes_done=self.done(),
                             episodes_planned=self.planned,
                             image_id=self.image_id).model_dump(mode="json"))
            except ChannelError as e:
                log.warning("heartbeat of %s: %s", self.work.id, e)
                if e.status == 409:  # cancelled, or its lease expired: stop the run
                    self.lost.set()
                    if self.work.kind == "run":
                        _thread.interrupt_main()
                    return
