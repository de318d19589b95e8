"""``eagc report``: the episode viewer's static pages, checked in a real headless Chromium.

A local sanity campaign (two teams, agents as plain processes, the overhead camera on) and
one Track 1 episode at a large camera resolution are run through the real worker; the
pages are written from the results store and the episode folders, then opened from disk
by Debian's ``chromium`` (``tests/orchestrator/_chromium.py``): no page logs a console
error, the scrubber changes the shown frame and step, a team's pages hold no other team
and nothing of the hidden scenario, and the organizer's view does. One screenshot per page
type is kept under pytest's temporary folder (the paths are printed).
"""

from __future__ import annotations

import json
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import yaml
from _chromium import Browser
from typer.testing import CliRunner

from orchestrator._campaign.seeds import commitment, load_secret, seed_list
from orchestrator._campaign.spec import campaign_dir, load_campaign, plan, store_path
from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._results.leaderboard import build_leaderboard
from orchestrator._results.store import ResultsStore
from orchestrator._runtimes.local import LocalProcessRuntime
from orchestrator._viewer import write_campaign_site, write_episode_site
from orchestrator._viewer.episode import diff
from orchestrator._viewer.frames import decode_png, encode_png
from orchestrator.cli.main import app
from schemas import CampaignSpec, EpisodeStatus, Limits

ROOT = Path(__file__).resolve().parents[2]
SANITY = f"python {ROOT / 'examples' / 'sanity_agent' / 'agent.py'}"
TRACK1 = f"python {ROOT / 'examples' / 'track1_heuristic' / 'agent.py'}"
TEAMS = ("team-alpha", "team-bravo")
CAMERA = {"render_rgbd": True, "image_size": [96, 72]}
#: A Track 1 episode page's ceiling, at the larger camera resolution below.
PAGE_LIMIT = 2 * 2**20
TRACK1_CAMERA = {"image_size": [640, 480]}
TRACK1_SEED = 7_340_212_881  # long: it must not turn up by chance


@dataclass
class Campaign:
    spec: CampaignSpec
    path: Path
    seeds: list[int]


@pytest.fixture(scope="module")
def shots(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("viewer-screenshots")


@pytest.fixture(scope="module")
def campaign() -> Campaign:
    folder = Path(tempfile.mkdtemp(prefix="eagc-vw-", dir="/tmp"))  # short: unix sockets
    name = "viewer-ci"
    doc = {"name": name, "track": "sanity", "phase": "local", "runtime": "local",
           "splits": [{"name": "standard", "weight": 0.6, "episodes": 1, "params": CAMERA},
                      {"name": "challenge", "weight": 0.4, "episodes": 1, "params": CAMERA}],
           "submissions": [{"team": t, "image": SANITY} for t in TEAMS],
           "limits": {"max_steps_per_stage": 400, "startup_s": 60.0, "pin_cpus": False},
           "retries": 0, "output": str(folder / "out")}
    path = folder / "campaign.yaml"
    path.write_text(yaml.safe_dump(doc))
    spec = load_campaign(path)
    seeds = seed_list(spec, load_secret(spec))
    by_key = {(s.split, s.index): s.seed for s in seeds}
    params = {s.name: s.params for s in spec.splits}
    runs = campaign_dir(spec)
    runs.mkdir(parents=True, mode=0o700)
    with ResultsStore(store_path(spec)) as store:
        keys = plan(spec)
        store.register(spec, commitment(spec, seeds), len(keys))
        for key in keys:
            result = run_episode(EpisodeSpec(
                track="sanity", image=SANITY, seed=by_key[(key.split, key.index)],
                split=key.split, params=params[key.split], limits=spec.limits,
                runs_dir=runs, index=key.index,
                labels={"campaign": name, "submission": key.submission}),
                LocalProcessRuntime(quiet=True))
            assert result.status is EpisodeStatus.COMPLETED, (key, result.failure)
            store.commit(name, key, result, retry=0, node=None)
    return Campaign(spec, path, [s.seed for s in seeds])


@pytest.fixture(scope="module")
def track1_episode() -> Path:
    runs = Path(tempfile.mkdtemp(prefix="eagc-vw-", dir="/tmp"))
    result = run_episode(EpisodeSpec(
        track="track1", image=TRACK1, seed=TRACK1_SEED, split="challenge", params=TRACK1_CAMERA,
        limits=Limits(max_steps_per_stage=80, time_scale=0.3, startup_s=60.0,
                      pin_cpus=False), runs_dir=runs), LocalProcessRuntime(quiet=True))
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    assert result.episode_dir is not None
    return Path(result.episode_dir)


def _hidden_values(episode_dir: Path) -> set[str]:
    """Strings of the hidden scenario that no team page may hold: its seed, and every
    number of its parameters written as the log writes it."""
    from mcap.reader import make_reader

    with (episode_dir / "host" / "episode.mcap").open("rb") as f:
        scenario = next(json.loads(m.data) for _, _, m in make_reader(f).iter_messages(
            topics=["/eagc/scenario"]))
    found = {str(scenario["seed"])}

    def walk(v: Any) -> None:
        if isinstance(v, dict):
            for x in v.values():
                walk(x)
        elif isinstance(v, list):
            for x in v:
                walk(x)
        elif isinstance(v, float) and len(repr(v)) > 6:
            found.add(json.dumps(v))

    walk(scenario.get("params"))
    return found


def _seed(episode_dir: Path) -> int:
    """The seed the episode's log says it ran."""
    from mcap.reader import make_reader

    with (episode_dir / "host" / "episode.mcap").open("rb") as f:
        return int(next(json.loads(m.data)["seed"] for _, _, m in make_reader(
            f).iter_messages(topics=["/eagc/scenario"])))


def _store(campaign: Campaign) -> ResultsStore:
    return ResultsStore(store_path(campaign.spec))


def _leaks(hidden: set[str], text: str) -> list[str]:
    return [h for h in hidden if re.search(rf"(?<![\d.]){re.escape(h)}(?!\d)", text)]


def _pages(folder: Path) -> list[Path]:
    return sorted(folder.rglob("*.html"))


def _site(campaign: Campaign, out: Path, **kw: Any) -> list[Path]:
    with _store(campaign) as store:
        return write_campaign_site(campaign.spec, store, out, **kw)


def _open_all(browser: Browser, folder: Path) -> None:
    for page in _pages(folder):
        errors = browser.open(page.as_uri())
        assert not errors, f"{page}: {errors}"


# --------------------------------------------------------------------------- pure parts
def test_snapshot_changes_name_what_changed() -> None:
    old = {"rooms": [{"id": 1, "type": "hall"}], "doors": [{"id": 3, "state": "open"}],
           "step": 4}
    new = {"rooms": [{"id": 1, "type": "hall"}, {"id": 2, "type": "kitchen"}],
           "doors": [{"id": 3, "state": "closed"}], "step": 9}
    assert diff(old, new) == ['+ rooms[id=2]: {"id": 2, "type": "kitchen"}',
                              "~ doors[id=3].state: open → closed", "~ step: 4 → 9"]


def test_thumbnails_round_trip() -> None:
    import numpy as np

    img = (np.arange(48 * 64 * 3) % 251).astype(np.uint8).reshape(48, 64, 3)
    assert (decode_png(encode_png(img)) == img).all()


def test_thumbnails_are_scaled_to_the_page_width_whatever_the_camera() -> None:
    import numpy as np

    from orchestrator._viewer.frames import THUMB_WIDTH, thumbnail

    small = np.full((72, 96, 3), 40, np.uint8)
    assert thumbnail(small) is small  # today's size stays as it was logged
    for w, h in ((256, 192), (224, 224), (640, 480)):
        flat = np.full((h, w, 3), 77, np.uint8)
        got = thumbnail(flat)
        assert got.shape == (round(h * THUMB_WIDTH / w), THUMB_WIDTH, 3) and (got == 77).all()
    stripes = np.zeros((192, 256, 3), np.uint8)
    stripes[:, 1::2] = 200  # an area filter averages what nearest sampling would alias
    assert abs(float(thumbnail(stripes).mean()) - 100.0) < 1.0
    labels = np.random.default_rng(0).choice([0, 90, 180], (192, 256, 3)).astype(np.uint8)
    assert set(np.unique(thumbnail(labels, smooth=False))) <= {0, 90, 180}


def test_a_long_textured_episode_at_the_official_size_keeps_its_frames_in_budget() -> None:
    import base64

    import numpy as np

    from orchestrator._viewer.frames import (
        FRAME_BUDGET,
        MAX_FRAMES,
        THUMB_WIDTH,
        Frame,
        decode_png,
        depth_picture,
        page_frames,
    )

    h, w = 192, 256
    scene = _textured(h, w + 200)
    ramp = np.linspace(0.5, 6.0, h)[:, None] * np.ones((1, w))
    labels = np.zeros((h, w, 3), np.uint8)
    labels[60:150, 40:120] = (30, 60, 90)
    frames = [Frame(step=k, rgb=scene[:, k:k + w], depth=depth_picture(ramp + 0.01 * k),
                    segmentation=np.roll(labels, k, axis=1)) for k in range(200)]
    kept = page_frames(frames)
    # every frame the count cap leaves fits the budget: textured RGB goes as JPEG
    assert len(kept) > MAX_FRAMES * 0.8 and kept[0]["step"] == 0 and kept[-1]["step"] == 199
    encoded = sum(len(str(f[k])) for f in kept for k in ("rgb", "depth", "segmentation"))
    assert encoded * 3 / 4 <= FRAME_BUDGET
    for f in (kept[0], kept[-1]):
        assert str(f["rgb"]).startswith("data:image/jpeg;base64,")
        jpeg = base64.b64decode(str(f["rgb"]).split(",", 1)[1])
        sof = jpeg.index(b"\xff\xc0")
        assert (int.from_bytes(jpeg[sof + 5:sof + 7]), int.from_bytes(jpeg[sof + 7:sof + 9])) \
            == (144, THUMB_WIDTH)
        for key in ("depth", "segmentation"):
            png = base64.b64decode(str(f[key]).split(",", 1)[1])
            assert decode_png(png).shape == (144, THUMB_WIDTH, 3)


def _textured(h: int, w: int) -> Any:
    """A deterministic picture as busy as a rendered textured scene (grain and edges)."""
    import numpy as np

    yy, xx = np.mgrid[0:h, 0:w].astype(float)
    rng = np.random.default_rng(3)
    base = np.stack([128 + 60 * np.sin(xx / 7 + c) * np.cos(yy / 11 - c) for c in (0, 1, 2)], -1)
    base[h // 3:, : w // 2] = (180, 140, 90)  # a flat panel and a hard edge
    grain = rng.normal(0, 6, (h, w, 1))
    return np.clip(base + grain, 0, 255).astype(np.uint8)


def test_rgb_thumbnails_are_jpeg_where_smaller_and_decode_in_chromium(
        browser: Browser, tmp_path: Path) -> None:
    import numpy as np

    from orchestrator._viewer.frames import compact_rgb, data_uri

    flat = np.full((72, 96, 3), (200, 30, 90), np.uint8)
    assert compact_rgb(flat)[1] == "image/png"  # a flat-shaded frame stays exact
    for h, w in ((144, 192), (37, 53)):
        img = _textured(h, w)
        data, mime = compact_rgb(img)
        assert mime == "image/jpeg" and len(data) * 3 < len(encode_png(img))
        page = tmp_path / f"jpeg{w}.html"
        page.write_text(f'<img id="i" src="{data_uri(data, mime)}">')
        assert not browser.open(page.as_uri())
        got = browser.evaluate(
            "(() => { const i = document.getElementById('i');"
            " const c = document.createElement('canvas');"
            " c.width = i.naturalWidth; c.height = i.naturalHeight;"
            " const x = c.getContext('2d'); x.drawImage(i, 0, 0);"
            " return [i.naturalWidth, i.naturalHeight,"
            " Array.from(x.getImageData(0, 0, c.width, c.height).data)]; })()")
        assert got[:2] == [w, h]
        shown = np.array(got[2], np.uint8).reshape(h, w, 4)[:, :, :3]
        assert np.abs(shown.astype(int) - img.astype(int)).mean() < 6.0


def test_frames_are_thinned_to_the_budget_keeping_both_ends() -> None:
    import numpy as np

    from orchestrator._viewer.frames import FRAME_BUDGET, MAX_FRAMES, Frame, page_frames

    rng = np.random.default_rng(0)
    noise = [Frame(step=5 * k, rgb=rng.integers(0, 256, (480, 640, 3), dtype=np.uint8))
             for k in range(300)]  # incompressible: the budget binds
    kept = page_frames(noise)
    assert 2 < len(kept) <= MAX_FRAMES
    assert kept[0]["step"] == 0 and kept[-1]["step"] == 5 * 299
    assert sum(len(str(f["rgb"])) for f in kept) * 3 / 4 <= FRAME_BUDGET * 1.01


# ------------------------------------------------------------------------- the campaign
@pytest.mark.slow
def test_the_index_is_the_leaderboard_with_every_team_linked(
        campaign: Campaign, browser: Browser, shots: Path, tmp_path: Path) -> None:
    out = tmp_path / "site"
    _site(campaign, out)
    with _store(campaign) as store:
        board = build_leaderboard(campaign.spec, store)
    _open_all(browser, out)
    browser.open((out / "index.html").as_uri())
    rows = browser.evaluate("Array.from(document.querySelectorAll('tr.team-row')).map("
                            "r => Array.from(r.cells).map(c => c.textContent.trim()))")
    assert [r[2] for r in rows] == [r.team for r in board.rows]
    assert [r[1] for r in rows] == [r.ranks for r in board.rows]
    assert [r.ci for r in board.rows][0] in rows[0]
    links = browser.evaluate("Array.from(document.querySelectorAll('tr.team-row a'))"
                             ".map(a => a.getAttribute('href'))")
    assert all((out / link).is_file() for link in links) and len(links) == len(TEAMS)
    print(f"\nscreenshot (index): {browser.screenshot(shots / 'index.png')}")
    browser.open((out / links[0]).as_uri())
    episodes = browser.evaluate("Array.from(document.querySelectorAll('#episodes a'))"
                                ".map(a => a.href)")
    assert len(episodes) == 2
    heads = browser.evaluate("Array.from(document.querySelectorAll('#episodes th'))"
                             ".map(c => c.textContent)")
    with _store(campaign) as store:
        components = set(store.results(campaign.spec.name)[0].result.score.components)
    assert {"Episode", "Verdict", "Score", *components} <= set(heads)
    print(f"screenshot (team): {browser.screenshot(shots / 'team.png')}")


@pytest.mark.slow
def test_a_team_sees_only_itself_and_no_hidden_scenario(
        campaign: Campaign, browser: Browser, tmp_path: Path) -> None:
    out = tmp_path / "alpha"
    pages = _site(campaign, out,
                                team=TEAMS[0])
    assert set(pages) == set(_pages(out)) and (out / "index.html") in pages
    with _store(campaign) as store:
        stored = store.results(campaign.spec.name)
    other = {e.result.episode for e in stored if e.key.submission != TEAMS[0]}
    hidden = set().union(*(_hidden_values(Path(e.result.episode_dir or "")) for e in stored))
    hidden |= {str(s) for s in campaign.seeds}
    for page in pages:
        text = page.read_text()
        assert TEAMS[1] not in text, page
        assert not [e for e in other if e in text], page
        leaked = _leaks(hidden, text)
        assert not leaked, (page, leaked[:5])
        assert "hidden-scenario" not in text and "/tmp/" not in text, page
        assert "model-vs-truth" not in text, page
    _open_all(browser, out)
    # The organizer's view of the same team holds the scenario.
    org = tmp_path / "org"
    _site(campaign, org,
                        team=TEAMS[0], organizer=True)
    episode = next(p for p in _pages(org) if p.parent.name == "episodes")
    assert "hidden-scenario" in episode.read_text()
    _open_all(browser, org)


@pytest.mark.slow
def test_the_scrubber_changes_the_shown_frame_and_step(
        campaign: Campaign, browser: Browser, tmp_path: Path) -> None:
    out = tmp_path / "site"
    _site(campaign, out,
                        team=TEAMS[1])
    page = next(p for p in _pages(out) if p.parent.name == "episodes")
    data = json.loads(re.search(r'id="episode-data">(.*?)</script>', page.read_text(),
                                re.S).group(1))
    steps = [f["step"] for f in data["frames"]]
    assert len(steps) >= 4, "frames by step: the scrubber covers the episode"
    assert steps[-1] >= data["last_step"] - 10
    shown = []
    for want in (steps[1], steps[-2]):
        assert not browser.open(f"{page.as_uri()}?step={want}")
        got = browser.evaluate("[document.body.dataset.step, document.body.dataset.frameStep,"
                               " document.getElementById('frame-rgb').src,"
                               " document.getElementById('step-label').textContent]")
        assert got[0] == got[3] == got[1] == str(want)
        shown.append(got[2])
    assert shown[0] != shown[1]
    assert shown[0].startswith(("data:image/png;base64,", "data:image/jpeg;base64,"))
    # Moving the slider as a user does.
    between = (steps[1] + steps[2]) // 2 if steps[2] - steps[1] > 1 else steps[1]
    got = browser.evaluate(
        f"(() => {{ const s = document.getElementById('step'); s.value = '{between}';"
        " s.dispatchEvent(new Event('input')); return [document.body.dataset.step,"
        " document.body.dataset.frameStep, document.getElementById('path').dataset.points];"
        " })()")
    assert got[:2] == [str(between), str(steps[1])] and int(got[2]) > 0


@pytest.mark.slow
def test_the_command_line(campaign: Campaign, tmp_path: Path) -> None:
    runner = CliRunner()
    got = runner.invoke(app, ["report", str(campaign.path), "--out", str(tmp_path / "a")])
    assert got.exit_code == 0, got.output
    assert (tmp_path / "a" / "index.html").is_file()
    assert got.output.splitlines()[-1].strip() == str(tmp_path / "a" / "index.html")
    assert all(len(line) <= 80 for line in got.output.splitlines()[:-1])
    got = runner.invoke(app, ["report", str(campaign.path), "--team", "team-alpa",
                              "--out", str(tmp_path / "b")])
    assert got.exit_code == 2 and "Did you mean 'team-alpha'?" in got.output
    with _store(campaign) as store:
        folder = store.results(campaign.spec.name)[0].result.episode_dir
    got = runner.invoke(app, ["report", str(folder), "--out", str(tmp_path / "c")])
    assert got.exit_code == 0 and (tmp_path / "c" / "index.html").is_file()
    got = runner.invoke(app, ["report", str(tmp_path / "nothing"), "--out", str(tmp_path)])
    assert got.exit_code == 2


# ---------------------------------------------------------------------------- Track 1
@pytest.mark.slow
def test_a_track1_episode_page(track1_episode: Path, browser: Browser, shots: Path,
                               tmp_path: Path) -> None:
    out = tmp_path / "t1"
    (page,) = write_episode_site(track1_episode, out)
    size = page.stat().st_size
    print(f"\nTrack 1 episode page at 640x480: {size / 2**20:.2f} MiB")
    assert size < PAGE_LIMIT
    text = page.read_text()
    assert "data:image/jpeg;base64," in text  # textured RGB frames go as JPEG thumbnails
    assert not _leaks(_hidden_values(track1_episode), text)
    assert not browser.open(page.as_uri())
    got = browser.evaluate("[document.querySelectorAll('#map-svg image').length,"
                           " document.querySelectorAll('#events tr[data-step]').length,"
                           " document.querySelectorAll('details.snapshot').length,"
                           " document.getElementById('frame-rgb').naturalWidth]")
    assert got[0] == 1 and got[1] > 5 and got[2] >= 3 and got[3] == 192  # 640 scaled to 192
    first = browser.evaluate("document.getElementById('path').dataset.points")
    browser.open(page.as_uri() + "?step=3")
    assert int(browser.evaluate("document.getElementById('path').dataset.points")) < int(first)
    browser.open(page.as_uri())
    print(f"screenshot (episode): {browser.screenshot(shots / 'episode.png')}")
    org = tmp_path / "org"
    (page,) = write_episode_site(track1_episode, org, organizer=True)
    assert "hidden-scenario" in page.read_text() and "model-vs-truth" in page.read_text()
    assert not browser.open(page.as_uri())
    # A hidden seed (a campaign's with a secret): the team's page draws the path alone,
    # never the house's plan (what its world model is graded on); the organizer's does.
    hidden = tmp_path / "hidden"
    (page,) = write_episode_site(track1_episode, hidden, public_seed=False)
    assert not browser.open(page.as_uri())
    assert browser.evaluate("document.querySelectorAll('#map-svg image').length") == 0
    assert int(browser.evaluate("document.getElementById('path').dataset.points")) > 1
    (page,) = write_episode_site(track1_episode, tmp_path / "h-org", organizer=True,
                                 public_seed=False)
    assert not browser.open(page.as_uri())
    assert browser.evaluate("document.querySelectorAll('#map-svg image').length") == 1


#: The window a team opens an episode page in: the score and its notes show on load.
WINDOW = (1280, 900)


@pytest.mark.slow
def test_the_score_and_its_first_note_are_in_view_on_load(
        track1_episode: Path, browser: Browser, shots: Path, tmp_path: Path) -> None:
    notes = json.loads((track1_episode / "host" / "result.json").read_text())[
        "score"]["notes"]
    assert notes, "the episode of the test has a note on its card"
    (page,) = write_episode_site(track1_episode, tmp_path / "fold")
    width, height = WINDOW
    browser.call("Emulation.setDeviceMetricsOverride", {
        "width": width, "height": height, "deviceScaleFactor": 1, "mobile": False},
        session=True)
    try:
        assert not browser.open(page.as_uri())
        got = browser.evaluate(
            "(() => { const box = e => { const r = e.getBoundingClientRect();"
            " return [r.top, r.bottom, e.textContent.trim()]; };"
            " return [window.innerWidth, window.innerHeight, window.scrollY,"
            " box(document.getElementById('score')),"
            " box(document.querySelector('#notes li'))]; })()")
        print(f"\nscreenshot (episode, {width}x{height}): "
              f"{browser.screenshot(shots / 'episode-fold.png')}")
    finally:
        browser.call("Emulation.clearDeviceMetricsOverride", session=True)
    (w, h, scrolled, score, note) = got
    assert (w, h, scrolled) == (width, height, 0)
    assert 0 <= score[0] and score[1] <= height, (score, height)
    assert score[2] == _pct(track1_episode)
    assert 0 <= note[0] and note[1] <= height, (note, height)
    assert note[2] == notes[0]


def _pct(episode: Path) -> str:
    total = json.loads((episode / "host" / "result.json").read_text())["score"]["total"]
    return f"{100 * total:.1f}"


# ------------------------------------------------------ run-episode folders, no campaign
CRASH = "python -c 'import sys; print(\"bad agent\"); sys.exit(7)'"


@pytest.mark.slow
def test_a_folder_of_run_episode_results_gets_a_team_page_without_a_campaign(
        track1_episode: Path, browser: Browser, shots: Path) -> None:
    """What a team has after a few ``eagc run-episode`` calls (two sanity seeds, an agent
    that crashes, a Track 1 episode, a preview beside them), as ``eagc report``'s pages."""
    import shutil

    runs = Path(tempfile.mkdtemp(prefix="eagc-vr-", dir="/tmp"))  # short: unix sockets
    try:
        _run_episode_folder(runs, track1_episode, browser, shots)
    finally:
        shutil.rmtree(runs, ignore_errors=True)


def _run_episode_folder(runs: Path, track1_episode: Path, browser: Browser,
                        shots: Path) -> None:
    import shutil

    runner = CliRunner()
    for seed, image, code in ((3, SANITY, 0), (11, SANITY, 0), (5, CRASH, 4)):
        got = runner.invoke(app, ["run-episode", "sanity", "--runtime", "local",
                                  "--image", image, "--seed", str(seed), "--runs-dir",
                                  str(runs), "--max-steps", "300"])
        assert got.exit_code == code, got.output
    shutil.copytree(track1_episode, runs / track1_episode.name)
    (runs / "previews").mkdir()
    (runs / "previews" / "track1-standard-seed0.png").write_bytes(b"\x89PNG")
    results = {p.parent.parent.name: json.loads(p.read_text())
               for p in runs.glob("*/host/result.json")}
    assert len(results) == 4
    out = runs / "site"
    got = runner.invoke(app, ["report", str(runs), "--out", str(out)])
    assert got.exit_code == 0, got.output
    assert got.output.splitlines()[-1].strip() == str(out / "index.html")
    assert f"{len(results) + 1} pages written" in got.output
    assert {p.stem for p in (out / "episodes").glob("*.html")} == set(results)
    _open_all(browser, out)

    browser.open((out / "index.html").as_uri())
    rows = browser.evaluate(
        "Array.from(document.querySelectorAll('table.episodes tbody tr')).map(r =>"
        " [r.querySelector('a').getAttribute('href'),"
        " ...Array.from(r.cells).map(c => c.textContent.trim())])")
    assert sorted(r[1] for r in rows) == sorted(results)
    for href, episode, split, seed, image, verdict, stage, score, *_ in rows:
        r = results[episode]
        assert href == f"episodes/{episode}.html" and (out / href).is_file()
        assert (split, image, verdict) == (r["split"], r["image"], r["status"])
        assert score == f"{100 * r['score']['total']:.1f}"
        assert stage == (r["stages_reached"] or ["none"])[-1]
        assert seed == str(_seed(runs / episode))
    assert sorted(int(r[3]) for r in rows if r[4] != TRACK1) == [3, 5, 11]
    assert [r[5] for r in rows if r[4] == CRASH] == ["agent_crash"]
    assert [r[5] for r in rows if r[4] == SANITY] == ["completed"] * 2
    tracks = browser.evaluate("Array.from(document.querySelectorAll('h2'))"
                              ".map(h => h.textContent.trim())")
    assert tracks == sorted({r["track"] for r in results.values()}) == ["sanity", "track1"]
    splits = browser.evaluate(
        "Array.from(document.querySelectorAll('table.splits tbody tr')).map(r =>"
        " Array.from(r.cells).map(c => c.textContent.trim()))")
    sanity = [r for r in results.values() if r["track"] == "sanity"]
    mean = sum(r["score"]["total"] for r in sanity) / len(sanity)
    done = sum(r["failure"] is None for r in sanity)
    assert ["standard", "3", str(done), f"{100 * mean:.1f}"] in splits
    print(f"\nscreenshot (run-episode folder): "
          f"{browser.screenshot(shots / 'runs.png')}")
    # An episode's page leads back to the folder's page.
    browser.open((out / rows[0][0]).as_uri())
    assert browser.evaluate("document.querySelector('a').getAttribute('href')") == \
        "../index.html"

    got = runner.invoke(app, ["report", str(runs), "--team", "x", "--out", str(out)])
    assert got.exit_code == 2 and "--team is for a campaign" in got.output
    got = runner.invoke(app, ["report", str(runs / "previews"), "--out", str(out)])
    assert got.exit_code == 2 and "holds none" in got.output, got.output


def test_the_wheel_carries_the_templates(tmp_path: Path) -> None:
    import zipfile

    from orchestrator._images.wheel import build_wheel

    names = set(zipfile.ZipFile(build_wheel(ROOT, tmp_path)).namelist())
    templates = ROOT / "orchestrator" / "_viewer" / "templates"
    assert {"base.html", "index.html", "team.html", "episode.html"} <= {
        p.name for p in templates.glob("*.html")}
    for path in templates.glob("*.html"):
        assert path.relative_to(ROOT).as_posix() in names
