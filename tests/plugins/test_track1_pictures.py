"""Track 1 pictures: a scenario's preview and an episode's trajectory from its MCAP log."""

from __future__ import annotations

import shutil
import struct
import tempfile
import zlib
from pathlib import Path

import numpy as np
import pytest

from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._runtimes.local import LocalProcessRuntime
from plugins import load_track
from plugins.track1 import trajectory_png
from plugins.track1._pictures import STAGE_COLOURS, _read_mcap, title_lines
from schemas import EpisodeStatus, Limits

ROOT = Path(__file__).resolve().parents[2]


def _read_png(path: Path) -> np.ndarray:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, size = 8, b"", (0, 0)
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        tag, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        if tag == b"IHDR":
            size = struct.unpack(">II", body[:8])
        elif tag == b"IDAT":
            idat += body
        pos += 12 + length
    w, h = size
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, w * 3 + 1)
    return raw[:, 1:].reshape(h, w, 3)


def _has(img: np.ndarray, rgb: tuple[int, int, int]) -> bool:
    return bool((img == np.array(rgb, np.uint8)).all(axis=2).any())


def _legend_has(img: np.ndarray, rgb: tuple[int, int, int]) -> bool:
    """A 10x10 legend swatch of this colour below the map."""
    rows = (img == np.array(rgb, np.uint8)).all(axis=2)
    return bool(rows[-60:].sum() >= 64)


def test_preview_shows_the_map_a_camera_frame_a_title_a_legend_and_a_scale(
        tmp_path: Path) -> None:
    path = load_track("track1").preview(seed=7, split="challenge", out=tmp_path / "pics")
    assert path == tmp_path / "pics" / "track1-challenge-7.png"
    img = _read_png(path)
    assert img.shape[0] >= 240 and img.shape[1] > 320 + 200
    camera = img[40:280, -320:]
    assert camera.std() > 5, "the camera frame is blank"
    assert _has(img, (220, 0, 200)) and _has(img, (0, 170, 210))  # the goals' rings
    assert (img[:30] < 60).all(axis=2).sum() > 200, "no title text"
    for colour in ((220, 0, 200), (0, 170, 210), (40, 170, 70), (70, 105, 160)):
        assert _legend_has(img, colour), colour
    assert (img[-20:] == 0).all(axis=2).any(axis=0).sum() >= 40, "no 1 m scale bar"


def test_trajectory_of_a_recorded_episode(tmp_path: Path) -> None:
    runs = Path(tempfile.mkdtemp(prefix="t1p-", dir="/tmp"))  # short: unix socket paths
    try:
        spec = EpisodeSpec(track="track1", seed=3, split="standard",
                           image=f"python {ROOT / 'examples' / 'track1_sanity' / 'agent.py'}",
                           limits=Limits(max_steps_per_stage=100, time_scale=0.1),
                           runs_dir=runs)
        result = run_episode(spec, LocalProcessRuntime(quiet=True))
        assert result.status is EpisodeStatus.COMPLETED, result.failure
        path = trajectory_png(result.episode_dir or "")
        assert path == Path(result.episode_dir or "") / "host" / "trajectory.png"
        # The title's score is the episode's (the MCAP's score record is its EpisodeResult).
        assert _read_mcap(path.with_name("episode.mcap"))[3] == result.score.total
        img = _read_png(path)
        assert _has(img, STAGE_COLOURS["exploration"]) and _has(img, STAGE_COLOURS["execution"])
        for colour in STAGE_COLOURS.values():
            assert _legend_has(img, colour), colour
    finally:
        shutil.rmtree(runs, ignore_errors=True)
    with pytest.raises(FileNotFoundError, match="episode folder"):
        trajectory_png(tmp_path)


def test_a_long_title_is_wrapped_within_the_picture() -> None:
    seed = "1234567890" * 4
    lines = title_lines([f"TRACK1 challenge seed {seed}: completed, score 42.0",
                         "task: put the mug in the sink"], 420)
    assert all(len(line) <= (420 - 16) // 8 for line in lines)
    assert " ".join(lines).replace(" ", "") == \
        f"TRACK1challengeseed{seed}:completed,score42.0task:putthemuginthesink"
