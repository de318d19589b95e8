"""``eagc challenge rehearse``: the whole calendar with the example teams, in minutes.

A real channel (``eagc challenge serve``: API, registry, runner on an embedded Ray) on a
compressed clock plays three phases of the sanity track, each an hour of the channel's
time: a testing phase with a public board; a qualification whose board gives the
finalists by their rank ranges; a final open to the finalists only, whose submissions are
frozen, signed into a manifest and verified, audited, ruled on and released. Teams push,
submit and follow through the channel's HTTP API as teams do; the organizer's steps are
the ``eagc challenge`` commands' own functions on the channel's data.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from orchestrator._channel.client import ChannelClient, Login, freeze, submit
from orchestrator._channel.db import ChannelError
from schemas import SubmissionState

Say = Callable[[str], None]
TEAMS = ("team-a", "team-b", "team-c")
#: Channel seconds per real second: an hour-long phase lasts a minute.
SPEED = 60.0
HOUR = 3600
SPLITS = [{"name": "standard", "episodes": 1, "weight": 0.6},
          {"name": "challenge", "episodes": 1, "weight": 0.4}]


def challenge_file(folder: Path) -> Path:
    """The rehearsal's CHALLENGE.yaml (three phases of an hour each)."""
    import yaml

    limits = {"memory_mb": 512, "max_steps_per_stage": 300}
    common = {"splits": SPLITS, "limits": limits, "retries": 1,
              "quota": {"per_day": 20, "concurrent": 2},
              "preflight": {"split": "standard", "seed": 1}}
    doc = {"name": "rehearsal", "track": "sanity", "teams": list(TEAMS),
           "lease_s": 30 * SPEED, "appeal_s": 10 * SPEED, "phases": [
               {"name": "testing", "kind": "testing", "opens": "start",
                "closes": "start+1h", "board": "public", **common},
               {"name": "qual", "kind": "qualification", "opens": "start+1h",
                "closes": "start+2h", "board": "team", **common},
               {"name": "final", "kind": "final", "who": "finalists", "opens": "start+2h",
                "closes": "start+3h", "board": "organizers", **common}]}
    path = folder / "challenge.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


class Rehearsal:
    """One rehearsal in ``output`` (its data folder kept short: unix sockets)."""

    def __init__(self, output: Path, image: str, disclosure: Path, say: Say) -> None:
        self.output, self.image, self.disclosure, self.say = output, image, disclosure, say
        output.mkdir(parents=True, exist_ok=True)
        self.data = Path(tempfile.mkdtemp(prefix="eagc-rh-", dir="/tmp"))
        self.proc: subprocess.Popen[bytes] | None = None
        self.url = ""
        self.tokens: dict[str, str] = {}
        self.refs: dict[str, str] = {}
        self._channel: Any = None

    # ------------------------------------------------------------------ the channel
    def start(self) -> None:
        spec = challenge_file(self.output)
        log = (self.output / "channel.log").open("ab")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "orchestrator.cli", "challenge", "serve", str(spec),
             "--data", str(self.data), "--port", "0", "--clock-speed", str(SPEED)],
            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.monotonic() + 90
        while not (self.data / "serve.json").is_file():
            if self.proc.poll() is not None or time.monotonic() > deadline:
                raise ChannelError(f"the channel did not start: see {self.output}/channel.log")
            time.sleep(0.2)
        self.url = json.loads((self.data / "serve.json").read_text())["url"]
        self._wait(lambda: self._answers(), 60, "the channel's API did not answer")
        ch = self.channel()
        self.tokens = {t: ch.db.new_token(t, 1)[0] for t in TEAMS}
        self.say(f"channel {self.url}, data {self.data}, clock x{SPEED:.0f}")

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(90)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)

    def _answers(self) -> bool:
        try:
            ChannelClient(self.url, "none").call("GET", "/api/v1/phases")
            return True
        except ChannelError:
            return False

    def channel(self) -> Any:
        """The channel's data as the organizer's commands open it (once: one database
        connection for the whole rehearsal)."""
        from orchestrator._channel.serve import open_channel

        if self._channel is None:
            self._channel = open_channel(self.data)
        return self._channel

    def _wait(self, done: Callable[[], Any], timeout_s: float, why: str) -> Any:
        deadline = time.monotonic() + timeout_s
        while True:
            got = done()
            if got:
                return got
            if time.monotonic() > deadline:
                raise ChannelError(f"rehearsal: {why} (see {self.output}/channel.log and "
                                   f"{self.data}/runner.log)")
            time.sleep(1.0)

    def until(self, phase: str, edge: str) -> None:
        """Waits for the channel's clock to reach ``phase``'s opening or closing."""
        ch = self.channel()
        w = next(w for w in ch.windows() if w.phase.name == phase)
        when = w.opens if edge == "opens" else w.closes
        assert when is not None
        self._wait(lambda: ch.clock.utc() >= when, 600, f"phase {phase} never {edge}")

    # ------------------------------------------------------------------ teams
    def login(self, team: str) -> Login:
        return Login(self.url, team, self.tokens[team])

    def submit(self, team: str) -> str:
        ref = self.refs.get(team, self.image)
        view = submit(ref, self.login(team), note=f"rehearsal, {team}",
                      disclosure=self.disclosure)
        self.refs[team] = view.image  # pushed once: later submissions by digest
        self.say(f"  {team} submitted {view.id}")
        return view.id

    def state(self, team: str, sid: str) -> SubmissionState:
        c = ChannelClient(self.url, self.tokens[team])
        return c.submission(sid).state

    def settle(self, ids: dict[str, str], *, until: tuple[SubmissionState, ...] = (
            SubmissionState.SCORED, SubmissionState.FAILED)) -> None:
        self._wait(lambda: all(self.state(t, s) in until for t, s in ids.items()), 900,
                   f"submissions {sorted(ids.values())} never reached {until}")

    # ------------------------------------------------------------------ the calendar
    def run(self) -> dict[str, Any]:
        from orchestrator._channel.final import verify, write_manifest
        from orchestrator._channel.release import audit_phase, findings, release, rule
        from orchestrator._results.finalists import finalists

        summary: dict[str, Any] = {"boards": {}}
        self.say("phase testing: team-a tries the channel")
        self.settle({"team-a": self.submit("team-a")})
        summary["boards"]["testing"] = self.board("testing")

        self.until("qual", "opens")
        self.say("phase qual: every team submits")
        self.settle({t: self.submit(t) for t in TEAMS})
        self.until("qual", "closes")
        summary["boards"]["qual"] = self.board("qual")

        ch = self.channel()
        cut = finalists(ch.board(ch.phase("qual")), 2)
        self.say(cut.to_text())
        ch.set_finalists(ch.phase("final"), list(cut.finalists), who="rehearsal",
                         why=f"rank ranges of phase qual within 2 ({cut.policy()})")
        summary["finalists"] = list(cut.finalists)

        self.until("final", "opens")
        self.say(f"phase final: the finalists {', '.join(cut.finalists)} submit and freeze")
        final = {t: self.submit(t) for t in cut.finalists}
        self.settle(final, until=(SubmissionState.QUEUED, SubmissionState.RUNNING,
                                  SubmissionState.SCORED))
        report = self.output / "report.md"
        report.write_text("# Technical report\n\nThe example sanity agent.\n")
        for team, sid in final.items():  # as a team does: `eagc freeze`, over the API
            got = freeze(sid, report, self.login(team))
            self.say(f"  {team} froze {sid}: report sha256 "
                     f"{got['files']['report']['sha256'][:12]}")
        self.settle(final)
        self.until("final", "closes")
        written = write_manifest(self.channel(), "final", self.output / "final")
        checks = list(verify(written.manifest))
        for c in checks:
            self.say(f"  verify: {'ok  ' if c.ok else 'FAIL'} {c.name}: {c.detail}")
        summary["manifest"] = str(written.manifest)
        summary["verified"] = all(c.ok for c in checks)

        ch = self.channel()
        found = audit_phase(ch, ch.phase("final"), 2, who="rehearsal", say=self.say)
        for f in findings(ch, "final"):
            rule(ch, f["id"], "accept", who="rehearsal", why="a rehearsal's finding")
        summary["findings"] = len(found)
        self._wait(lambda: not self._held(), 120, "the appeal windows never closed")
        pages = release(self.channel(), self.channel().phase("final"),
                        self.output / "public", who="rehearsal", why="rehearsal")
        summary["boards"]["final"] = json.loads((self.output / "public" /
                                                 "board.json").read_text())["rows"]
        summary["public"] = str(pages[-1])
        (self.output / "rehearsal.json").write_text(json.dumps(summary, indent=1))
        return summary

    def _held(self) -> list[str]:
        from orchestrator._channel.release import holds

        return holds(self.channel(), "final")

    def board(self, phase: str) -> list[dict[str, Any]]:
        b = self.channel().board(self.channel().phase(phase))
        rows = [] if b is None else [{"rank": r.rank, "ranks": r.ranks, "team": r.team,
                                      "final": r.final} for r in b.rows]
        for r in rows:
            self.say(f"  {phase}: {r['rank']} ({r['ranks']}) {r['team']} "
                     f"{'—' if r['final'] is None else format(r['final'], '.1f')}")
        return rows
