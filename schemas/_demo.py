"""The Track 2 demonstration packet's manifest (``eagc-demo/v2``), read-only in ``/input/demo``.

A packet is a folder::

    manifest.json      DemoManifest (below), UTF-8 JSON
    trajectory.npz     arrays, read with numpy.load(..., allow_pickle=False)
    frames/            optional PNGs of the overview camera, frames/<obs index:06d>.png

It holds what a real demonstration gives: the actions, the observations the demonstrator's
robot made (through the split's observation channel: noisy, delayed, occluded on the
official splits), key-stage names with coarse boundaries, state-change annotations and
optional frames. It holds no source parameters, no goal array and no per-step true stage.

Step indexing: ``observations[k]`` is what the robot saw before its ``k``-th action
(``k = 0`` is the reset observation), so ``T`` actions come with ``T + 1`` observations.
A key stage covers the observation indices ``[start, end)``; boundaries are rounded to
multiples of ``boundary_resolution`` observations (an annotator's marks, not the truth). An
annotation's ``step`` is the first observation index at which its event holds.

Arrays in ``trajectory.npz``: ``actions (T, 5) float32``; ``obs_<key> (T + 1, ...) float32``
for every key of ``observation_spec`` (``proprio``, ``parts``, ``force``, and ``goal`` on
the dev split); with depth frames, ``frame_depth (F, H, W) float32`` (metres) for the steps
``frames.steps``.
"""

from __future__ import annotations

from typing import Final, Literal

from pydantic import BaseModel, ConfigDict, Field

DEMO_VERSION: Final = "eagc-demo/v2"


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
    description: str = ""


class KeyStage(_Frozen):
    """A key stage over observation indices ``[start, end)`` (coarse boundaries)."""

    name: str
    start: int = Field(ge=0)
    end: int = Field(ge=1)


class Annotation(_Frozen):
    """A state change: ``event`` happened to ``part``, first seen at observation ``step``.

    Events: ``grasped``/``released`` (a grasp begins/ends), ``lifted``, ``dropped`` and the
    family's goal event — ``inserted`` (insertion), ``turned`` (rotation), ``placed``
    (assembly), ``opened``/``closed`` (opening), ``pressed``/``aligned`` (tool use).
    ``value`` is set on the goal event only. On the official splits an annotation states
    what an annotator can state and the observations cannot show: ``opened``/``closed``
    carry the opening fraction reached, to a tenth (0 closed, 1 fully open: the joint's
    range is not in the observations); every other magnitude (the depth, the turn, ...) is
    not given and must be read off the demonstration's observations. On the public ``dev``
    split every goal event carries the magnitude the demonstration reached at its end —
    ``inserted``: depth (m); ``turned``: the angle turned (rad, + counter-clockwise seen from
    above); ``placed``: parts placed; ``opened``/``closed``: the opening fraction;
    ``pressed``: the button's travel (m); ``aligned``: the puck's offset from the goal line
    along x (m).
    """

    step: int = Field(ge=0)
    event: str
    part: str
    value: float | None = None


class FrameSpec(_Frozen):
    """Rendered frames: ``folder/<index:06d>.png`` for every listed observation index."""

    folder: str = "frames"
    camera: str = "overview"
    height: int
    width: int
    steps: list[int]
    depth: bool = Field(False, description="``frame_depth`` in trajectory.npz holds depth "
                        "images (m) of the same steps.")


class DemoManifest(_Frozen):
    """``manifest.json`` of a demonstration packet (``eagc-demo/v2``)."""

    version: Literal["eagc-demo/v2"] = DEMO_VERSION
    family: Literal["insertion", "rotation", "assembly", "opening", "tool_use"]
    control_hz: int
    num_steps: int = Field(ge=0, description="T, the number of actions.")
    success: bool = Field(description="Whether the demonstration reached its goal.")
    action_spec: ArraySpec
    action_scale: dict[str, float] = Field(
        description="dx, dy, dz: m per step at 1; dyaw: rad per step at 1; grip: the finger "
        "opening (m) at +1, closed at -1."
    )
    observation_spec: dict[str, ArraySpec]
    stage_names: list[str] = Field(description="Ordered key stages of the task.")
    key_stages: list[KeyStage]
    boundary_resolution: int = Field(ge=1, description="Key-stage boundaries are rounded to "
                                     "multiples of this many observations.")
    events: list[Annotation]
    frames: FrameSpec | None = None
