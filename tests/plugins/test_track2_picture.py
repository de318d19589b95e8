"""The Track 2 pictures say what they show (issue 23 §2): the attempt's picture carries
the episode's score in its title and the values of its axes; the preview explains its
DISTANCE and DRAWS.

The words drawn are recorded from the raster's ``Canvas.text`` (the pictures are pixels).
"""

from __future__ import annotations

import re
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._runtimes.local import LocalProcessRuntime
from plugins import load_track
from schemas import EpisodeStatus, Limits
from simhost.worlds.track2._raster import Canvas

TRACK = load_track("track2")


@pytest.fixture()
def drawn(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Every string drawn on a canvas while the test runs."""
    words: list[str] = []
    text = Canvas.text

    def record(self: Canvas, y: int, x: int, s: str, *args: object, **kw: object) -> None:
        words.append(s)
        text(self, y, x, s, *args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(Canvas, "text", record)
    return words


@pytest.fixture()
def runs() -> Iterator[Path]:
    folder = Path(tempfile.mkdtemp(prefix="eagc-tp-", dir="/tmp"))  # short: socket paths
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.mark.slow
def test_the_attempt_picture_shows_the_score_and_axis_values(runs: Path,
                                                             drawn: list[str]) -> None:
    spec = EpisodeSpec(track="track2", image="python examples/track2_waypoint/agent.py",
                       seed=4101, params={"demo_frames": False}, runs_dir=runs,
                       limits=Limits(startup_s=60.0, pin_cpus=False))
    r = run_episode(spec, LocalProcessRuntime(quiet=True))
    assert r.status is EpisodeStatus.COMPLETED, r.failure
    drawn.clear()
    png = TRACK.picture(Path(r.episode_dir or ""))
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    (title,) = [w for w in drawn if w.startswith("TRACK2 SEED")]
    assert f"SCORE {100 * r.score.total:.1f}" in title and len(title) <= 82, title
    values = [w for w in drawn if re.fullmatch(r"[XYZ] -?\d+\.\d+( M)?|-?\d+\.\d+ M", w)]
    assert {w[0] for w in values if w[0] in "XYZ"} == {"X", "Y", "Z"}, drawn
    assert len(values) == 8, values  # 4 per panel: both ends of both axes


def test_the_preview_explains_distance_and_draws(tmp_path: Path, drawn: list[str]) -> None:
    TRACK.preview(seed=3, split="standard", out=tmp_path)
    said = " ".join(drawn)
    assert re.search(r"DISTANCE \d\.\d\d: HOW FAR THE INSTANCE IS FROM THE SOURCE", said), said
    assert re.search(r"DRAWS \d+: INSTANCES DRAWN UNTIL", said), said
