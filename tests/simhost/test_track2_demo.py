"""Demonstration packets (eagc-demo/v2): write, read back, replay, what they hold and what
they do not, broken packets; the comparison picture."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from schemas import DemoManifest
from simhost.worlds.track2 import (
    FAMILIES,
    BenchEnv,
    DemoPacketError,
    expert_policy,
    read_demo_packet,
    render_attempt_vs_demo,
    sample_instance,
    split_config,
    task_truth,
    write_demo_packet,
)
from simhost.worlds.track2._demo import coarse_stages
from simhost.worlds.track2._raster import decode_png


@pytest.fixture(scope="module")
def packet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("demo") / "insertion"
    write_demo_packet(folder, sample_instance("insertion", 4), seed=1, frames=True)
    return folder


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("split", ["dev", "standard"])
def test_round_trip(family: str, split: str, tmp_path: Path) -> None:
    params = sample_instance(family, 30)
    bench = split_config(split).bench
    written = write_demo_packet(tmp_path / "p", params, seed=0, config=bench)
    pk = read_demo_packet(tmp_path / "p")
    man = pk.manifest
    assert man == written and man.success and man.version == "eagc-demo/v2"
    assert man.family == family
    assert man.stage_names == list(task_truth(params).stages)
    t = man.num_steps
    assert set(pk.arrays) == {"actions", *(f"obs_{k}" for k in man.observation_spec)}
    assert ("obs_goal" in pk.arrays) == (split == "dev"), "a goal only where the split states it"
    assert pk.arrays["actions"].shape == (t, 5)
    assert pk.arrays["obs_proprio"].shape == (t + 1, 7)
    assert pk.arrays["obs_parts"].shape[1:] == tuple(man.observation_spec["parts"].shape)
    # key stages tile the run in order, with boundaries on the annotator's grid
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
    goals = ("inserted", "turned", "placed", "opened", "closed", "pressed", "aligned")
    assert any(e.event in goals for e in man.events), "the goal event is annotated"
    valued = [e for e in man.events if e.value is not None]
    if split == "dev":  # today's level: the magnitude reached, as a number
        assert valued and all(e.event in goals for e in valued)
    else:  # what an annotator states: an opening's fraction to a tenth, nothing else
        assert all(e.event in ("opened", "closed") for e in valued)
        assert all(round(e.value, 1) == e.value for e in valued)
        assert bool(valued) == (family == "opening")
    raw = (tmp_path / "p" / "manifest.json").read_text()
    secrets = ["source", "friction", "seed", "progress", "reward"]
    if split != "dev":
        secrets.append('"goal"')
    for secret in secrets:
        assert secret not in raw, secret
    assert DemoManifest.model_validate_json(raw) == man  # what an agent reads


@pytest.mark.parametrize("split", ["dev", "standard"])
def test_official_demo_shows_the_result_at_rest(split: str, tmp_path: Path) -> None:
    """Without a magnitude in the annotation, the official packet goes on after the goal: the
    hand rises, so the released parts are seen past it at rest; dev's packet ends on it."""
    from simhost.worlds.track2._demo import DRAW_BACK_Z, GOAL_EVENTS, POST_STEPS

    params = sample_instance("rotation", 30)
    man = write_demo_packet(tmp_path / "p", params, seed=0, config=split_config(split).bench)
    hand = read_demo_packet(tmp_path / "p").arrays["obs_proprio"]
    goal = max(e.step for e in man.events if e.event in GOAL_EVENTS)
    if split == "dev":  # ends on success, a few steps after the goal event (a release)
        assert man.num_steps - goal < POST_STEPS
        return
    assert man.num_steps >= goal + POST_STEPS
    assert hand[-1, 2] > DRAW_BACK_Z - 0.02 > hand[goal, 2] + 0.05, "the hand drew back"
    assert np.all(np.diff(hand[-POST_STEPS:, 2]) > -0.001), "up, never down"
    parts = read_demo_packet(tmp_path / "p").arrays["obs_parts"]
    assert np.ptp(parts[-8:, 0, 1:4], axis=0).max() < 0.01, "the knob at rest"
    assert parts[-1, 0, 9] < 0.2, "and freshly measured: the hand no longer hides it"


def test_coarse_stage_boundaries_are_rounded_but_ordered() -> None:
    names = ["reach", "grasp", "turn", "release"]
    stages = [0] * 23 + [1] * 2 + [2] * 31 + [3] * 9 + [-1]
    ks = coarse_stages(stages, names, 10)
    assert [(k.name, k.start, k.end) for k in ks] == [
        ("reach", 0, 20), ("grasp", 20, 21), ("turn", 21, 60), ("release", 60, 65)]


def test_official_packet_observations_are_noisy(tmp_path: Path) -> None:
    params = sample_instance("insertion", 3)
    write_demo_packet(tmp_path / "dev", params, seed=2)
    write_demo_packet(tmp_path / "std", params, seed=2, config=split_config("standard").bench)
    dev, std = (read_demo_packet(tmp_path / k).arrays["obs_parts"] for k in ("dev", "std"))
    hole_dev, hole_std = dev[:, 1, 1:4], std[:, 1, 1:4]
    assert np.ptp(hole_dev, axis=0).max() < 1e-9, "dev: exact, the hole never moves"
    assert np.ptp(hole_std, axis=0).max() > 0.001, "official: measured with noise"
    assert np.all(std[:, :, 8] == 0.0), "no joint readings"


def test_replaying_the_demo_actions_reproduces_it(packet: Path) -> None:
    pk = read_demo_packet(packet)
    env = BenchEnv(sample_instance("insertion", 4))
    obs, _ = env.reset(seed=1)
    assert np.array_equal(obs["proprio"], pk.arrays["obs_proprio"][0])
    for a in pk.arrays["actions"]:
        obs, _, _, _, info = env.step(a)
    assert info["success"]
    assert np.array_equal(obs["parts"], pk.arrays["obs_parts"][-1])


def test_frames_are_pngs_with_depth(packet: Path) -> None:
    pk = read_demo_packet(packet)
    paths = pk.frame_paths()
    f = pk.manifest.frames
    assert len(paths) >= 10 and f is not None and f.depth
    img = decode_png(paths[0].read_bytes())
    assert img.shape == (f.height, f.width, 3)
    depth = pk.arrays["frame_depth"]
    assert depth.shape == (len(f.steps), f.height, f.width)
    assert 0.2 < float(depth.min()) < float(depth.max()) <= 10.0  # background clipped at 10 m


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
    with pytest.raises(DemoPacketError, match="does not match eagc-demo/v2"):
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


def test_attempt_vs_demo_picture(packet: Path, tmp_path: Path) -> None:
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
    out = tmp_path / "attempt_vs_demo.png"
    png = render_attempt_vs_demo(pk, np.array(path), attempt_frames=frames, path=out)
    assert out.read_bytes() == png
    img = decode_png(png)
    assert img.shape[1] == 2 * 320 + 36 and img.shape[0] > 320 + 4 * 100
    colours = {tuple(c) for c in img.reshape(-1, 3)[::7]}
    assert (40, 90, 200) in colours and (235, 120, 20) in colours  # both paths drawn
    with pytest.raises(ValueError, match="non-empty finite"):
        render_attempt_vs_demo(pk, np.array([[np.nan, 0.0, 0.0]]))
