"""Reading a demonstration packet (``eagc-demo/v2``; the format is in ``schemas._demo``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError

from schemas import DEMO_VERSION, DemoManifest

from ._errors import DemoPacketError

OBS_KEYS = ("proprio", "parts", "force", "goal")
"""Observation keys a packet may carry as ``obs_<key>`` arrays (images go to frames)."""


class DemoPacket(BaseModel):
    """A packet read back from disk: its manifest, arrays and folder."""

    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True, extra="forbid")

    folder: Path
    manifest: DemoManifest
    arrays: dict[str, np.ndarray]

    def frame_paths(self) -> list[Path]:
        f = self.manifest.frames
        if f is None:
            return []
        return [self.folder / f.folder / f"{k:06d}.png" for k in f.steps]


def read_demo_packet(folder: str | Path) -> DemoPacket:
    """Read and check a packet; raises :class:`DemoPacketError` saying what is wrong."""
    root = Path(folder)
    if not root.is_dir():
        raise DemoPacketError(f"demonstration packet folder {root} does not exist")
    mpath = root / "manifest.json"
    if not mpath.is_file():
        raise DemoPacketError(f"{root} has no manifest.json: not a demonstration packet")
    try:
        raw = json.loads(mpath.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DemoPacketError(f"{mpath} is not valid JSON: {exc}") from exc
    if isinstance(raw, dict) and raw.get("version") != DEMO_VERSION:
        raise DemoPacketError(
            f"{mpath}: version {raw.get('version')!r} is not supported (expected {DEMO_VERSION!r})"
        )
    try:
        man = DemoManifest.model_validate(raw)
    except ValidationError as exc:
        raise DemoPacketError(f"{mpath} does not match {DEMO_VERSION}:\n{exc}") from exc
    tpath = root / "trajectory.npz"
    if not tpath.is_file():
        raise DemoPacketError(f"{root} has no trajectory.npz")
    try:
        with np.load(tpath, allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
    except (OSError, ValueError, EOFError) as exc:
        raise DemoPacketError(f"{tpath} cannot be read without pickle: {exc}") from exc
    _check_arrays(man, arrays, tpath)
    _check_labels(man)
    for p in DemoPacket(folder=root, manifest=man, arrays={}).frame_paths():
        if not p.is_file():
            raise DemoPacketError(f"frame {p} is listed in the manifest but missing")
    return DemoPacket(folder=root, manifest=man, arrays=arrays)


def _check_arrays(man: DemoManifest, arrays: dict[str, np.ndarray], where: Path) -> None:
    t = man.num_steps
    want: dict[str, tuple[tuple[int, ...], str]] = {
        "actions": ((t, *man.action_spec.shape), "float32"),
    }
    for key, spec in man.observation_spec.items():
        want[f"obs_{key}"] = ((t + 1, *spec.shape), "float32")
    f = man.frames
    if f is not None and f.depth:
        want["frame_depth"] = ((len(f.steps), f.height, f.width), "float32")
    missing = sorted(set(want) - set(arrays))
    if missing:
        raise DemoPacketError(f"{where} lacks arrays {missing}")
    for name, (shape, dtype) in want.items():
        a = arrays[name]
        if a.shape != shape or str(a.dtype) != dtype:
            raise DemoPacketError(
                f"{where}: {name} is {a.dtype}{list(a.shape)}, expected {dtype}{list(shape)} "
                f"for num_steps={t}"
            )
        if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
            raise DemoPacketError(f"{where}: {name} holds NaN or Inf")


def _check_labels(man: DemoManifest) -> None:
    t = man.num_steps
    prev_end = 0
    for ks in man.key_stages:
        if ks.name not in man.stage_names:
            raise DemoPacketError(f"key stage {ks.name!r} is not in stage_names {man.stage_names}")
        if not ks.start < ks.end <= t + 1 or ks.start < prev_end:
            raise DemoPacketError(
                f"key stage {ks.name!r} [{ks.start}, {ks.end}) is out of order or outside "
                f"[0, {t + 1})"
            )
        prev_end = ks.end
    for ev in man.events:
        if ev.step > t:
            raise DemoPacketError(f"annotation {ev.event}/{ev.part} at step {ev.step} > {t}")
    if man.frames is not None and any(not 0 <= k <= t for k in man.frames.steps):
        raise DemoPacketError(f"frame steps outside [0, {t}]")
