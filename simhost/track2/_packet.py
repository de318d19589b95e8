"""The demonstration packet (``eagc-demo/v1``): what a Track 2 team receives, read-only.

A packet is a folder::

    manifest.json      DemoManifest (below), UTF-8 JSON
    trajectory.npz     arrays, read with numpy.load(..., allow_pickle=False)
    frames/            optional PNGs of the overview camera, frames/<obs index:06d>.png

Step indexing: ``observations[k]`` is what the expert saw before its ``k``-th action
(``k = 0`` is the reset observation), so ``T`` actions come with ``T + 1`` observations.
A key stage covers the observation indices ``[start, end)``; an annotation's ``step`` is the
first observation index at which its event holds. Events are the family's (see its module:
``grasped``, ``lifted``, ``inserted``, ``turned``, ``placed``, ``opened``/``closed``,
``pressed``, ``aligned``) plus ``released`` (a grasp ends) and ``dropped`` (a loose part
falls freely).

Arrays in ``trajectory.npz``: ``actions (T, 5) float32``; ``obs_<key> (T + 1, ...)``
``float32`` for every observation key (``proprio``, ``parts``, ``force``, ``goal``);
``reward (T,) float32``; ``progress (T + 1,) float32``; ``stage (T + 1,) int16`` — the
index into ``manifest.stage_names`` of the true stage at each observation, ``-1`` once done.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ._errors import DemoPacketError
from ._params import Family

DEMO_VERSION = "eagc-demo/v1"
OBS_KEYS = ("proprio", "parts", "force", "goal")


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class ArraySpec(_Frozen):
    """Shape, dtype, bounds and element names of one array."""

    shape: tuple[int, ...]
    dtype: str
    low: float
    high: float
    names: list[str] = Field(default_factory=list, description="Names along the last axis.")
    rows: list[str] = Field(default_factory=list, description="Row names (``parts`` only).")


class KeyStage(_Frozen):
    """A key stage over observation indices ``[start, end)``."""

    name: str
    start: int = Field(ge=0)
    end: int = Field(ge=1)


class Annotation(_Frozen):
    """A state change: ``event`` happened to ``part`` first seen at observation ``step``."""

    step: int = Field(ge=0)
    event: str
    part: str


class FrameSpec(_Frozen):
    """Rendered frames: ``folder/<index:06d>.png`` for every listed observation index."""

    folder: str = "frames"
    camera: str = "overview"
    height: int
    width: int
    steps: list[int]


class DemoManifest(_Frozen):
    """``manifest.json`` of a demonstration packet."""

    version: Literal["eagc-demo/v1"] = DEMO_VERSION
    family: Family
    source: dict[str, Any] = Field(description="Public parameters of the source instance.")
    control_hz: int
    physics_dt: float
    substeps: int
    num_steps: int = Field(ge=0, description="T, the number of actions.")
    success: bool = Field(
        description="Whether the expert reached the goal (if not, demonstrate another source)."
    )
    action_spec: ArraySpec
    action_scale: dict[str, float] = Field(
        description="dx, dy, dz: m per step at 1; dyaw: rad per step at 1; grip: the finger "
        "opening (m) at +1, closed at -1."
    )
    observation_spec: dict[str, ArraySpec]
    stage_names: list[str] = Field(description="Ordered key stages of the task.")
    key_stages: list[KeyStage]
    events: list[Annotation]
    frames: FrameSpec | None = None


class DemoPacket(_Frozen):
    """A packet read back from disk: its manifest, arrays and folder."""

    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True)

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
        raise DemoPacketError(f"{mpath} does not match eagc-demo/v1:\n{exc}") from exc
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
        "reward": ((t,), "float32"),
        "progress": ((t + 1,), "float32"),
        "stage": ((t + 1,), "int16"),
    }
    for key, spec in man.observation_spec.items():
        want[f"obs_{key}"] = ((t + 1, *spec.shape), "float32")
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
    stage = arrays["stage"]
    if np.any((stage < -1) | (stage >= len(man.stage_names))):
        raise DemoPacketError(f"{where}: stage indices outside [-1, {len(man.stage_names)})")


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
