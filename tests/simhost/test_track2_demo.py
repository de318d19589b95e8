"""Demonstration packets: write, read back, replay, broken packets; the comparison picture."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from simhost.track2 import (
    FAMILIES,
    BenchEnv,
    DemoPacketError,
    expert_policy,
    read_demo_packet,
    render_attempt_vs_demo,
    sample_instance,
    task_truth,
    write_demo_packet,
)
from simhost.track2._raster import decode_png


@pytest.fixture(scope="module")
def packet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("demo") / "insertion"
    write_demo_packet(folder, sample_instance("insertion", 4), seed=1, frames=True)
    return folder


@pytest.mark.parametrize("family", FAMILIES)
def test_round_trip(family: str, tmp_path: Path) -> None:
    params = sample_instance(family, 30)
    written = write_demo_packet(tmp_path / "p", params, seed=0)
    pk = read_demo_packet(tmp_path / "p")
    man = pk.manifest
    assert man == written and man.success and man.version == "eagc-demo/v1"
    assert man.family == family and man.source == params.public()
    assert man.stage_names == task_truth(params)["stages"]
    t = man.num_steps
    assert pk.arrays["actions"].shape == (t, 5)
    assert pk.arrays["obs_proprio"].shape == (t + 1, 7)
    assert pk.arrays["obs_parts"].shape[1:] == tuple(man.observation_spec["parts"].shape)
    # key stages tile the run in order, ending where the task is done
    assert man.key_stages[0].start == 0
    assert [k.name for k in man.key_stages] == sorted(
        (k.name for k in man.key_stages), key=man.stage_names.index
    )
    for a, b in zip(man.key_stages, man.key_stages[1:], strict=False):
        assert a.end == b.start
    assert man.key_stages[-1].end == t
    assert any(e.event == "grasped" for e in man.events)
    assert not any(e.event == "dropped" for e in man.events)
    assert all(0 < e.step <= t for e in man.events)
    raw = json.loads((tmp_path / "p" / "manifest.json").read_text())
    assert "friction" not in raw["source"] and "seed" not in json.dumps(raw)


def test_replaying_the_demo_actions_reproduces_it(packet: Path) -> None:
    pk = read_demo_packet(packet)
    env = BenchEnv(sample_instance("insertion", 4))
    obs, _ = env.reset(seed=1)
    assert np.array_equal(obs["proprio"], pk.arrays["obs_proprio"][0])
    for a in pk.arrays["actions"]:
        obs, _, _, _, info = env.step(a)
    assert info["success"]
    assert np.array_equal(obs["parts"], pk.arrays["obs_parts"][-1])


def test_frames_are_pngs(packet: Path) -> None:
    pk = read_demo_packet(packet)
    paths = pk.frame_paths()
    assert len(paths) >= 10 and pk.manifest.frames is not None
    img = decode_png(paths[0].read_bytes())
    assert img.shape == (pk.manifest.frames.height, pk.manifest.frames.width, 3)


def test_refuses_to_overwrite(packet: Path) -> None:
    with pytest.raises(DemoPacketError, match="already holds"):
        write_demo_packet(packet, sample_instance("insertion", 4), seed=1)


def _broken(packet: Path, tmp_path: Path) -> Path:
    dst = tmp_path / "broken"
    shutil.copytree(packet, dst)
    return dst


def _edit_manifest(folder: Path, **changes: object) -> None:
    path = folder / "manifest.json"
    raw = json.loads(path.read_text())
    raw.update(changes)
    path.write_text(json.dumps(raw))


def test_broken_packets_give_clear_errors(packet: Path, tmp_path: Path) -> None:
    with pytest.raises(DemoPacketError, match="does not exist"):
        read_demo_packet(tmp_path / "nowhere")

    bad = _broken(packet, tmp_path)
    (bad / "manifest.json").write_text("{not json")
    with pytest.raises(DemoPacketError, match="not valid JSON"):
        read_demo_packet(bad)
    shutil.rmtree(bad)

    bad = _broken(packet, tmp_path)
    _edit_manifest(bad, version="eagc-demo/v9")
    with pytest.raises(DemoPacketError, match="not supported"):
        read_demo_packet(bad)
    shutil.rmtree(bad)

    bad = _broken(packet, tmp_path)
    _edit_manifest(bad, num_steps=3)
    with pytest.raises(DemoPacketError, match="expected float32"):
        read_demo_packet(bad)
    shutil.rmtree(bad)

    bad = _broken(packet, tmp_path)
    raw = json.loads((bad / "manifest.json").read_text())
    _edit_manifest(bad, key_stages=list(reversed(raw["key_stages"])))
    with pytest.raises(DemoPacketError, match="out of order"):
        read_demo_packet(bad)
    shutil.rmtree(bad)

    bad = _broken(packet, tmp_path)
    _edit_manifest(bad, family="juggling")
    with pytest.raises(DemoPacketError, match="does not match eagc-demo/v1"):
        read_demo_packet(bad)
    shutil.rmtree(bad)

    bad = _broken(packet, tmp_path)
    arrays = dict(np.load(bad / "trajectory.npz"))
    arrays["actions"] = np.array([{"evil": 1}] * len(arrays["actions"]), dtype=object)
    np.savez(bad / "trajectory.npz", **arrays)
    with pytest.raises(DemoPacketError, match="without pickle"):
        read_demo_packet(bad)
    shutil.rmtree(bad)

    bad = _broken(packet, tmp_path)
    del arrays["actions"]
    np.savez(bad / "trajectory.npz", **arrays)
    with pytest.raises(DemoPacketError, match=r"lacks arrays \['actions'\]"):
        read_demo_packet(bad)
    shutil.rmtree(bad)

    bad = _broken(packet, tmp_path)
    next((bad / "frames").iterdir()).unlink()
    with pytest.raises(DemoPacketError, match="missing"):
        read_demo_packet(bad)


def test_attempt_vs_demo_picture(packet: Path) -> None:
    pk = read_demo_packet(packet)
    env = BenchEnv(sample_instance("insertion", 40, source=sample_instance("insertion", 4)),
                   render_mode="rgb_array", image_size=(120, 160))
    obs, _ = env.reset(seed=0)
    path, frames = [obs["proprio"]], [env.render()]
    for k in range(env.max_steps):
        obs, _, terminated, truncated, _ = env.step(expert_policy(env))
        path.append(obs["proprio"])
        if k % 10 == 0:
            frames.append(env.render())
        if terminated or truncated:
            break
    out = Path("/tmp/track2_attempt_vs_demo.png")
    png = render_attempt_vs_demo(pk, np.array(path), attempt_frames=frames, path=out)
    assert out.read_bytes() == png
    img = decode_png(png)
    assert img.shape[1] == 2 * 320 + 36 and img.shape[0] > 320 + 4 * 100
    colours = {tuple(c) for c in img.reshape(-1, 3)[::7]}
    assert (40, 90, 200) in colours and (235, 120, 20) in colours  # both paths drawn
    with pytest.raises(ValueError, match="non-empty finite"):
        render_attempt_vs_demo(pk, np.array([[np.nan, 0.0, 0.0]]))
