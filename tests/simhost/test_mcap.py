"""The MCAP log of a real episode, read back: Foxglove's images and poses are in it.

A sanity episode with the overhead camera on (``render_rgbd``, as Track 1 renders RGB-D)
runs end to end with the example agent as a local process; the log must hold the camera as
``foxglove.CompressedImage`` (PNG that decodes to the observation's size), depth as
``foxglove.RawImage`` (32FC1, metres), segmentation, the robot's pose every step as
``foxglove.FrameTransforms`` and its whole path as ``foxglove.PosesInFrame``, while the
images stay at a low rate.
"""

from __future__ import annotations

import base64
import json
import struct
import tempfile
import zlib
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
from mcap.reader import make_reader

from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._runtimes.local import LocalProcessRuntime
from schemas import EpisodeStatus
from simhost.host._mcap import segmentation_colours

AGENT = Path(__file__).resolve().parents[2] / "examples" / "sanity_agent" / "agent.py"
W, H = 48, 32


def _png_size_and_pixels(data: bytes) -> tuple[int, int, np.ndarray]:
    """Width, height and pixels of a PNG from our encoder (8-bit RGB, filter none)."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    w, h = struct.unpack(">II", data[16:24])
    idat, pos = b"", 8
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos : pos + 4])
        tag = data[pos + 4 : pos + 8]
        if tag == b"IDAT":
            idat += data[pos + 8 : pos + 8 + n]
        pos += 12 + n
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, 1 + w * 3)
    return w, h, raw[:, 1:].reshape(h, w, 3)


def _read(path: Path) -> dict[str, list[tuple[str, int, Any]]]:
    """Topic → [(schema name, log time, decoded JSON)] for the JSON channels."""
    out: dict[str, list[tuple[str, int, Any]]] = defaultdict(list)
    with path.open("rb") as f:
        for schema, channel, message in make_reader(f).iter_messages(log_time_order=True):
            if channel.message_encoding == "json":
                out[channel.topic].append(
                    (schema.name if schema else "", message.log_time, json.loads(message.data)))
    return out


def test_a_rendered_episode_logs_images_and_poses_for_foxglove():
    runs = Path(tempfile.mkdtemp(prefix="eagc-", dir="/tmp"))
    result = run_episode(
        EpisodeSpec(track="sanity", image=f"python {AGENT}", seed=7, split="challenge",
                    params={"render_rgbd": True, "image_size": [W, H]}, runs_dir=runs),
        LocalProcessRuntime(quiet=True),
    )
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    log = _read(Path(result.mcap or ""))
    steps = len(log["/eagc/state_hash"])
    assert steps == result.stats.steps > 10

    # The camera, at a low rate: far fewer frames than steps, but some.
    rgb = log["/camera/rgb"]
    assert rgb and all(s == "foxglove.CompressedImage" for s, _, _ in rgb)
    assert len(rgb) < steps / 2
    first = rgb[0][2]
    assert first["format"] == "png" and first["frame_id"]
    assert set(first["timestamp"]) == {"sec", "nsec"}
    w, h, pixels = _png_size_and_pixels(base64.b64decode(first["data"]))
    assert (w, h) == (W, H) and pixels.std() > 0  # a real picture, not a blank

    depth = log["/camera/depth"]
    assert len(depth) == len(rgb) and all(s == "foxglove.RawImage" for s, _, _ in depth)
    d = depth[0][2]
    assert (d["width"], d["height"], d["encoding"], d["step"]) == (W, H, "32FC1", W * 4)
    metres = np.frombuffer(base64.b64decode(d["data"]), "<f4").reshape(H, W)
    assert 5.0 < float(metres[H // 2, W // 2]) < 6.0  # the floor, 6 m below the camera

    seg = log["/camera/segmentation"]
    assert len(seg) == len(rgb) and all(s == "foxglove.CompressedImage" for s, _, _ in seg)
    _, _, colours = _png_size_and_pixels(base64.b64decode(seg[0][2]["data"]))
    assert len({tuple(c) for c in colours.reshape(-1, 3)}) >= 3  # floor, walls, robot, …

    # Poses: a transform message per step (and after reset) under the world frame …
    tf = log["/tf"]
    assert all(s == "foxglove.FrameTransforms" for s, _, _ in tf)
    assert len(tf) == steps + 1
    frames = {t["child_frame_id"]: t for t in tf[0][2]["transforms"]}
    assert set(frames) == {"robot", "target"}
    assert frames["robot"]["parent_frame_id"] == "world"
    scenario = log["/eagc/scenario"][0][2]["params"]
    start = frames["robot"]["translation"]
    assert np.allclose([start["x"], start["y"]], scenario["start"], atol=1e-6)

    # … and the robot's whole path once, for the 3D panel.
    (schema, _, path), = log["/trajectory/robot"]
    assert schema == "foxglove.PosesInFrame" and path["frame_id"] == "world"
    xy = np.array([[p["position"]["x"], p["position"]["y"]] for p in path["poses"]])
    assert len(xy) == steps + 1
    assert np.allclose(xy[0], scenario["start"], atol=1e-6)
    assert np.linalg.norm(np.diff(xy, axis=0), axis=1).sum() > 1.0  # it went somewhere


def test_segmentation_colours_are_fixed_per_id_and_black_for_nothing():
    ids = np.array([[-1, 0, 1], [1, 0, 2_000_000]], np.int32)
    c = segmentation_colours(ids)
    assert c.dtype == np.uint8 and c.shape == (2, 3, 3)
    assert (c[0, 0] == 0).all() and (c[0, 1] == c[1, 1]).all() and (c[0, 2] == c[1, 0]).all()
    assert not (c[0, 1] == c[0, 2]).all() and (c[ids >= 0] > 0).any(axis=-1).all()
