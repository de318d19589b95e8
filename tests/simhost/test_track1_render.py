"""Pictures: the numpy top-down renderer (PNG) and headless RGB-D from the robot's camera."""

from __future__ import annotations

import json
import os
import pathlib
import struct
import subprocess
import sys
import zlib

import numpy as np

from simhost.worlds.track1 import HouseEnv, generate_house, make_action, render_topdown

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _read_png(path: pathlib.Path) -> np.ndarray:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, size = 8, b"", (0, 0)
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        tag, body = data[pos + 4 : pos + 8], data[pos + 8 : pos + 8 + length]
        (crc,) = struct.unpack(">I", data[pos + 8 + length : pos + 12 + length])
        assert crc == zlib.crc32(tag + body) & 0xFFFFFFFF
        if tag == b"IHDR":
            size = struct.unpack(">II", body[:8])
            assert body[8:10] == b"\x08\x02"  # 8-bit RGB
        elif tag == b"IDAT":
            idat += body
        pos += 12 + length
    w, h = size
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, w * 3 + 1)
    assert (raw[:, 0] == 0).all()
    return raw[:, 1:].reshape(h, w, 3)


def _has_colour(img: np.ndarray, rgb: tuple[int, int, int]) -> bool:
    return bool((img == np.array(rgb, np.uint8)).all(axis=2).any())


def test_topdown_png_of_a_layout(tmp_path: pathlib.Path) -> None:
    layout = generate_house(3)
    out = tmp_path / "house.png"
    img = render_topdown(layout, path=out)
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
    width, height = layout.extent
    assert (
        abs(img.shape[1] - (width * 48 + 24)) <= 2 and abs(img.shape[0] - (height * 48 + 24)) <= 2
    )
    assert np.array_equal(_read_png(out), img)
    assert _has_colour(img, (40, 40, 190))  # the robot


def test_topdown_of_an_env_shows_states_and_trajectory(tmp_path: pathlib.Path) -> None:
    env = HouseEnv()
    env.reset(seed=3)
    assert not _has_colour(render_topdown(env), (210, 30, 30))
    trajectory = []
    for _ in range(4):
        obs = env.step(make_action("move", forward=1.0, turn=0.3))[0]
        trajectory.append(obs["odometry"][:2].tolist())
    env.lock_door(env.layout.doors[0].id)
    img = render_topdown(env, trajectory=trajectory, path=tmp_path / "env.png")
    assert _has_colour(img, (210, 30, 30))  # a locked door is red
    assert _has_colour(img, (225, 0, 200))  # the trajectory
    assert (tmp_path / "env.png").stat().st_size > 1000


_RGBD = """
import json, os, sys
import numpy as np
from simhost.worlds.track1 import HouseEnv, make_action
assert os.environ["MUJOCO_GL"] == "egl" and "DISPLAY" not in os.environ
env = HouseEnv(render_rgbd=True, image_size=(96, 72))
obs, info = env.reset(seed=3)
table = next(f for f in env.layout.furniture if f.kind == "furniture"
             and any(i.receptacle == f.id for i in env.layout.items))
x, y, yaw = table.access
env.teleport_robot(x - 0.8 * np.cos(yaw), y - 0.8 * np.sin(yaw), yaw)
obs, _, _, _, info = env.step(make_action("noop"))
assert env.observation_space.contains(obs)
seen = [d["id"] for d in info["detections"]]
print(json.dumps({
    "rgb": [list(obs["rgb"].shape), str(obs["rgb"].dtype), int(obs["rgb"].std() > 5)],
    "depth": [list(obs["depth"].shape), str(obs["depth"].dtype),
              float(obs["depth"].min()), float(obs["depth"].max())],
    "seg": sorted(int(v) for v in np.unique(obs["segmentation"])),
    "table": table.id, "seen": seen,
    "ids": [e.id for e in (*env.layout.doors, *env.layout.furniture, *env.layout.items)],
}))
"""


def test_rgbd_renders_headless_with_egl() -> None:
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    env["MUJOCO_GL"] = "egl"
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    done = subprocess.run(
        [sys.executable, "-c", _RGBD],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert out["rgb"] == [[72, 96, 3], "uint8", 1]
    assert out["depth"][:2] == [[72, 96], "float32"] and 0.0 < out["depth"][2] < out["depth"][3]
    assert out["table"] in out["seg"] and -1 in out["seg"]
    assert set(out["seg"]) <= set(out["ids"]) | {-1}
    assert out["table"] in out["seen"]
