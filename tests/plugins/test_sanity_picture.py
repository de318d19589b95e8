"""The sanity track draws its episodes (issue 23 §2): the arena from above with the point
robot's path by stage, its start, the target (and where the exception moved it), a title
with the outcome and the score, a legend and a 1 m scale bar."""

from __future__ import annotations

import shutil
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from plugins.sanity._picture import MOVED, SCALE, STAGE_COLOURS, START, TARGET
from plugins.sanity._track import SanityTrack
from simhost.worlds.track2._raster import decode_png

AGENT = Path(__file__).resolve().parents[2] / "examples" / "sanity_agent" / "agent.py"


@pytest.fixture(scope="module")
def episode() -> Iterator[Path]:
    from orchestrator._episode.worker import EpisodeSpec, run_episode
    from orchestrator._runtimes.local import LocalProcessRuntime

    runs = Path(tempfile.mkdtemp(prefix="eagc-sp-", dir="/tmp"))  # short: socket paths
    result = run_episode(EpisodeSpec(track="sanity", image=f"{sys.executable} {AGENT}",
                                     seed=3, split="challenge", runs_dir=runs),
                         LocalProcessRuntime(quiet=True))
    assert result.status.value == "completed", result.failure
    yield runs / result.episode
    shutil.rmtree(runs, ignore_errors=True)


def _has(img: np.ndarray, colour: tuple[int, int, int], at_least: int = 20) -> bool:
    return int(np.all(img == np.asarray(colour, np.uint8), axis=-1).sum()) >= at_least


def test_sanity_draws_the_path_the_target_a_title_and_a_scale(episode: Path,
                                                               tmp_path: Path) -> None:
    out = tmp_path / "pics" / "sanity.png"
    path = SanityTrack().picture(episode, out)
    assert path == out and path.is_file()
    img = decode_png(path.read_bytes())
    assert img.shape[0] > 4 * SCALE and img.shape[1] >= 4 * SCALE
    for colour in (*STAGE_COLOURS.values(), START, TARGET, MOVED):  # seed 3: it moved
        assert _has(img, colour), colour
    assert not np.all(img[:14] == 255)  # a title
    bar = np.all(img[-40:] == 0, axis=-1).sum(axis=1)  # the scale bar: 1 m of black
    assert bar.max() >= SCALE


def test_the_default_place_is_the_episode_host_folder(episode: Path) -> None:
    assert SanityTrack().picture(episode) == episode / "host" / "path.png"


def test_a_folder_of_another_track_or_none_is_refused(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        SanityTrack().picture(tmp_path)
