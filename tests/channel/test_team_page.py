"""The team page (``orchestrator/_channel/pages.py``) in a real headless Chromium
(``tests/orchestrator/_chromium.py``), against a real channel served by uvicorn: its
database with the clock frozen, its results store, its board; submissions moved through
their states as a runner would move them (no registry, no Docker). A team logs in through
the form and sees its submissions queued, running, scored and failed, its quota and its reset, the
scored one's splits with intervals and its rank range, a public episode in the viewer; no
console error, no seed; another team's cookie shows none of it."""

from __future__ import annotations

import re
import secrets
import shutil
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import pytest
import requests

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "orchestrator"))
from _chromium import Browser  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _served import serve_app  # noqa: E402

from orchestrator._campaign.seeds import load_secret, seed_list  # noqa: E402
from orchestrator._channel.api import create_app  # noqa: E402
from orchestrator._channel.channel import Channel  # noqa: E402
from orchestrator._channel.db import Clock  # noqa: E402
from orchestrator._channel.registry import RegistryProcess  # noqa: E402
from orchestrator._episode.worker import EpisodeSpec, run_episode  # noqa: E402
from orchestrator._runtimes.local import LocalProcessRuntime  # noqa: E402
from schemas import (  # noqa: E402
    ChallengeSpec,
    EpisodeResult,
    EpisodeRow,
    EpisodeStats,
    EpisodeStatus,
    Limits,
    Outcome,
    Progress,
    ScoreCard,
    SubmitRequest,
)

ROOT = Path(__file__).resolve().parents[2]
SANITY = f"python {ROOT / 'examples' / 'sanity_agent' / 'agent.py'}"
T0 = datetime(2026, 5, 1, 12, 0, tzinfo=UTC).timestamp()
#: Track 1: ``standard`` is hidden, ``vision`` declared public by the phase (its episodes
#: open in the viewer).
SPEC = ChallengeSpec.model_validate({
    "name": "page-ci", "track": "track1", "teams": ["team-a", "team-b"],
    "phases": [{"name": "open", "closes": "start+30d", "retries": 1,
                "quota": {"per_day": 5, "concurrent": 3}, "public_splits": ["vision"],
                "splits": [{"name": "standard", "episodes": 3, "weight": 0.7},
                           {"name": "vision", "episodes": 2, "weight": 0.3}]}]})
WIDTH, HEIGHT = 1280, 900


@dataclass
class Served:
    channel: Channel
    url: str
    tokens: dict[str, str]
    ids: dict[str, str]  # team-a's queued, running, scored, failed submissions; team-b's
    shots: Path


def _result(split: str, total: float, status: EpisodeStatus = EpisodeStatus.COMPLETED,
            folder: str | None = None) -> EpisodeResult:
    return EpisodeResult(
        episode="ep" + secrets.token_hex(8), track="track1", split=split, image="img",
        runtime="docker", status=status, episode_dir=folder,
        score=ScoreCard(track="track1", total=total, components={}, weights={},
                        metrics={"task_success": 1.0, "model_verification": 0.5}),
        stats=EpisodeStats(steps=10, wall_s=1.0), started_at=0.0, finished_at=1.0)


def _accept(ch: Channel, team: str, note: str) -> str:
    return ch.accept(team, ch.open_phase(), f"teams/{team}/agent",
                     "sha256:" + secrets.token_hex(32), SubmitRequest(image="x", note=note)).id


def _passed(ch: Channel, sid: str) -> None:
    work = ch.claim("r", "preflight")
    assert work is not None and work.id == sid
    ch.report(sid, Outcome(runner="r", kind="preflight", ok=True,
                           reason="the container meets the contract"))
    ch.clock.origin += 30


def _score(ch: Channel, sid: str, base: float, folder: str | None) -> None:
    work = ch.claim("r", "run")
    assert work is not None and work.id == sid
    rows = [EpisodeRow(split="standard", index=i, result=_result(
        "standard", base + 0.05 * i,
        EpisodeStatus.AGENT_TIMEOUT if i == 2 else EpisodeStatus.COMPLETED))
        for i in range(3)]
    rows += [EpisodeRow(split="vision", index=i, result=_result(
        "vision", base + 0.1 * i, folder=folder if i == 0 else None)) for i in range(2)]
    ch.report(sid, Outcome(runner="r", kind="run", ok=True, wall_s=600.0,
                           results=tuple(rows)))
    ch.clock.origin += 60


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    data = Path(tempfile.mkdtemp(prefix="eagc-tp-", dir="/tmp"))  # short: unix sockets
    ch = Channel(SPEC, data, clock=Clock(origin=T0, speed=0.0))  # frozen: the test moves it
    ch.add_spec_teams()
    ch.registry = RegistryProcess(data / "registry", ch.keys, realm="http://unused",
                                  port=5999)  # its address only: nothing is pulled
    # One real episode in the channel's runs, as a runner beside the API leaves it: the
    # public split's first episode opens in the viewer.
    episode = run_episode(EpisodeSpec(
        track="sanity", image=SANITY, seed=7, split="standard", runs_dir=data / "runs",
        limits=Limits(max_steps_per_stage=200, startup_s=60.0, pin_cpus=False)),
        LocalProcessRuntime(quiet=True))
    assert episode.status is EpisodeStatus.COMPLETED, episode.failure
    ids = {}
    ids["b-scored"] = _accept(ch, "team-b", "team-b's own try")
    _passed(ch, ids["b-scored"])
    _score(ch, ids["b-scored"], 0.40, None)
    ids["failed"] = _accept(ch, "team-a", "arm64 build")
    assert ch.claim("r", "preflight") is not None
    ch.report(ids["failed"], Outcome(runner="r", kind="preflight", ok=False,
                                     reason="the container starts: exec format error"))
    ch.clock.origin += 30
    ids["scored"] = _accept(ch, "team-a", "first try")
    _passed(ch, ids["scored"])
    _score(ch, ids["scored"], 0.60, episode.episode_dir)
    ids["running"] = _accept(ch, "team-a", "bigger map")
    _passed(ch, ids["running"])
    assert ch.claim("r", "run") is not None
    ch.heartbeat(ids["running"], Progress(runner="r", episodes_done=2, episodes_planned=5))
    ids["queued"] = _accept(ch, "team-a", "faster planner")
    _passed(ch, ids["queued"])
    tokens = {t: ch.db.new_token(t, days=30)[0] for t in ("team-a", "team-b")}

    app = create_app(ch)
    app.state.pages.refresh_s = 1  # the page's own refresh, shortened
    try:
        with serve_app(app, "team-page") as url:
            yield Served(ch, url, tokens, ids, tmp_path_factory.mktemp("team-page"))
    finally:
        ch.db.close()
        shutil.rmtree(data, ignore_errors=True)


def _log_in(b: Browser, url: str, team: str, token: str) -> list[str]:
    """Fills the form as a person does and submits it; the form page's errors."""
    errors = b.open(f"{url}/login")
    assert b.evaluate("document.title").startswith("Log in")
    _submit(b, team, token)
    return errors


def _submit(b: Browser, team: str, token: str) -> None:
    b.events.clear()
    b.evaluate(f"document.getElementById('team').value = {team!r};"
               f"document.getElementById('token').value = {token!r};"
               "document.querySelector('form button').click(); 1")
    b.wait_for("Page.loadEventFired")


def _text(b: Browser) -> str:
    return str(b.evaluate("document.documentElement.outerHTML"))


def _hidden_seeds(ch: Channel) -> set[str]:
    """The phase's seeds of its hidden split, as text: none may reach a team's page."""
    spec = ch.campaign(ch.open_phase(), ch.data / "runs")
    return {str(s.seed) for s in seed_list(spec, load_secret(spec)) if s.split == "standard"}


def test_a_team_sees_its_submissions_queued_running_and_scored(
        browser: Browser, served: Served) -> None:
    b, ids = browser, served.ids
    b.call("Emulation.setDeviceMetricsOverride", {"width": WIDTH, "height": HEIGHT,
                                                  "deviceScaleFactor": 1, "mobile": False},
           session=True)
    assert b.open(f"{served.url}/team") == []  # no cookie: the form
    assert b.evaluate("location.pathname") == "/login"
    _submit(b, "team-a", "eagc_typo")
    assert "not one the channel issued" in str(
        b.evaluate("document.getElementById('problem').innerText"))
    b.screenshot(served.shots / "login-refused.png")
    assert _log_in(b, served.url, "team-a", served.tokens["team-a"]) == []
    assert b.evaluate("location.pathname") == "/team"
    assert b.evaluate("document.cookie") == ""  # HttpOnly: no script reads the token
    errors = b.open(f"{served.url}/team")
    assert errors == []
    html = _text(b)
    text = str(b.evaluate("document.body.innerText"))

    # The three states, newest first, each with what it waits for.
    rows = b.evaluate("[...document.querySelectorAll('tr.submission')].map("
                      "r => [r.dataset.id, r.dataset.state, r.innerText])")
    assert [(i, s) for i, s, _ in rows] == [
        (ids["queued"], "queued"), (ids["running"], "running"), (ids["scored"], "scored"),
        (ids["failed"], "failed")]
    assert "position 1 · ETA in about 6 min (2026-05-01 12:" in rows[0][2]
    assert "2/5 episodes" in rows[1][2]
    assert re.search(r"final 65\.0 \[\d+\.\d, \d+\.\d\]", rows[2][2]), rows[2][2]
    assert "pre-flight: the container starts: exec format error" in rows[3][2]
    assert "(not charged)" in rows[3][2]
    # The quota and when it resets.
    quota = str(b.evaluate("document.getElementById('quota').innerText"))
    assert "2 of 5" in quota and "2 of 3 at a time" in quota, quota
    assert re.search(r"refunded today\s+1\b", quota) and "1 of 10 a day" in quota, quota
    assert "2026-05-02 00:00 UTC" in quota
    assert "Phase open (testing) is open" in text and "2026-05-31 12:00 UTC" in text
    # The scored one's splits with intervals and verdicts, its rank range on the board.
    card = str(b.evaluate(f"document.getElementById('score-{ids['scored']}').innerText"))
    assert "rank 1 of 2 on the board" in card, card
    splits = b.evaluate(f"[...document.querySelectorAll('#score-{ids['scored']} tr.split')]"
                        ".map(r => [...r.cells].map(c => c.innerText))")
    assert [s[0] for s in splits] == ["standard", "vision (public)"]
    assert splits[0][1:] == ["65.0", "[60.0, 70.0]", "3", "1 agent_timeout, 2 completed"]
    assert splits[1][1:3] == ["65.0", "[60.0, 70.0]"]
    # Of the public split each episode's score; the one whose folder is here, linked.
    links = b.evaluate(f"[...document.querySelectorAll('#score-{ids['scored']} "
                       ".episode a')].map(a => a.getAttribute('href'))")
    assert links == [f"/team/episodes/{ids['scored']}/vision/0"]
    assert "vision/1 completed 70.0" in card
    # Never a seed, a hidden episode's score, a log, or another team's submission.
    assert "seed" not in html.lower()
    assert not [s for s in _hidden_seeds(served.channel) if s in html]
    assert ids["b-scored"] not in html and "team-b's own try" not in html
    assert "standard/0" not in html
    assert "States" in text and "cancelled" in text  # the legend

    # Above the fold at 1280x900: the states, the quota, the final and its splits.
    b.screenshot(served.shots / "team-page.png")
    for selector in ("#quota", "#submissions", f"#score-{ids['scored']} .final",
                     f"#score-{ids['scored']} tr[data-split=vision]"):
        bottom = b.evaluate(f"document.querySelector({selector!r})"
                            ".getBoundingClientRect().bottom")
        assert 0 < bottom <= HEIGHT, (selector, bottom)

    # The public episode in the viewer, with no console error.
    assert b.open(f"{served.url}{links[0]}") == []
    assert b.evaluate("document.getElementById('verdict').innerText") == "completed"
    b.screenshot(served.shots / "public-episode.png")
    assert b.evaluate("document.querySelector('a[href=\"/team\"]') !== null")
    assert "seed" not in str(b.evaluate("document.body.innerText")).lower()
    # A hidden split's episode has no page.
    b.open(f"{served.url}/team/episodes/{ids['scored']}/standard/0")  # a 404
    assert "no public split 'standard'" in str(b.evaluate("document.body.innerText"))

    # While something waits or runs the page refreshes in place: the queued one,
    # cancelled behind its back, shows so without a reload; an open history stays open.
    b.open(f"{served.url}/team")
    b.evaluate(f"window.marker = 1; document.getElementById('h-{ids['scored']}').open = true")
    served.channel.cancel(ids["queued"], team="team-a")
    deadline = time.monotonic() + 10
    state = ""
    while state != "cancelled":
        assert time.monotonic() < deadline, state
        time.sleep(0.2)
        state = b.evaluate(f"document.querySelector('tr[data-id=\"{ids['queued']}\"]')"
                           ".dataset.state")
    assert b.evaluate("window.marker") == 1
    assert b.evaluate(f"document.getElementById('h-{ids['scored']}').open") is True


def test_another_teams_cookie_never_shows_the_first_teams_submissions(
        browser: Browser, served: Served) -> None:
    b, ids = browser, served.ids
    b.open(f"{served.url}/logout")
    assert b.evaluate("location.pathname") == "/login"
    assert _log_in(b, served.url, "team-b", served.tokens["team-b"]) == []
    assert b.open(f"{served.url}/team") == []
    html = _text(b)
    rows = b.evaluate("[...document.querySelectorAll('tr.submission')].map("
                      "r => r.dataset.id)")
    assert rows == [ids["b-scored"]]
    assert not [sid for key, sid in ids.items() if key != "b-scored" and sid in html]
    assert "first try" not in html and "team-a" not in html
    assert "rank 2 of 2 on the board" in str(b.evaluate("document.body.innerText"))
    # team-a's public episode: "not found", as a submission that does not exist.
    b.open(f"{served.url}/team/episodes/{ids['scored']}/vision/0")
    assert str(b.evaluate("document.getElementById('problem').innerText")) == (
        f"no submission {ids['scored']!r} of team team-b")


def test_refusals_are_the_apis_and_the_cookie_is_strict(served: Served) -> None:
    url, ch = served.url, served.channel
    s = requests.Session()
    r = s.post(f"{url}/login", data={"team": "team-a", "token": "eagc_nope"})
    assert r.status_code == 401 and "not one the channel issued" in r.text
    r = s.post(f"{url}/login", data={"team": "team-b", "token": served.tokens["team-a"]})
    assert r.status_code == 401 and "this token is team team-a" in r.text
    r = s.post(f"{url}/login", data={"team": "team-a", "token": served.tokens["team-a"]},
               allow_redirects=False)
    assert r.status_code == 303 and r.headers["location"] == "/team"
    cookie = r.headers["set-cookie"].lower()
    assert "httponly" in cookie and "samesite=strict" in cookie
    assert "content-security-policy" in s.get(f"{url}/team").headers
    # A token replaced since: the page says so, as the API does, and forgets the cookie.
    ch.db.new_token("team-a", days=30)
    r = s.get(f"{url}/team")
    assert r.status_code == 401 and "was revoked on 2026-05-01" in r.text
    assert s.get(f"{url}/team", allow_redirects=False).status_code == 303  # to /login


def test_the_calendar_shows_every_window_in_utc_and_aoe(served: Served,
                                                        browser: Browser) -> None:
    errors = browser.open(f"{served.url}/calendar")
    assert not errors, errors
    assert browser.evaluate("document.title") == "page-ci: calendar"
    row = str(browser.evaluate(
        "document.querySelector('tr[data-phase=open]').innerText"))
    # The phase opens at the channel's first start (T0, 12:00 UTC) and closes 30 days on:
    # 12:00 UTC is 00:00 the same day Anywhere on Earth.
    assert "2026-05-01 12:00 UTC" in row and "2026-05-31 12:00 UTC" in row
    assert "2026-05-31 00:00 AoE" in row
    phases = requests.get(f"{served.url}/api/v1/phases", timeout=10).json()
    assert phases[0]["commitment"][:16] in row
    # Its seeds stay secret while it is open.
    sealed = requests.get(f"{served.url}/api/v1/phases/open/seeds", timeout=10)
    assert sealed.status_code == 403 and "revealed after" in sealed.json()["detail"]


def test_the_board_shows_what_the_phase_allows(served: Served) -> None:
    token, _ = served.channel.db.new_token("team-a", 30)  # an earlier test revoked its first
    auth = {"Authorization": f"Bearer {token}"}
    board = requests.get(f"{served.url}/api/v1/board", headers=auth, timeout=30).json()
    assert board["board"] == "team" and board["teams"] == 2  # two teams scored
    assert [r["team"] for r in board["rows"]] == ["team-a"]  # its own row only
