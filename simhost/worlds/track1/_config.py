"""Options of the Track 1 environment, grouped in one frozen model.

Sensing is what a robot has on the official splits: a forward field of view and range (line
of sight as before), position noise growing with distance, missed detections, some things
read as a look-alike category or colour from afar (the same way every time), odometry
drift, the room read from a sign when the robot enters it, and exceptions that show only
through their effects. The ``dev`` split keeps
exact, all-round perception (every knob at its default). Every random draw comes from a
generator keyed by the episode's noise seed (and the step count, but for what each thing
looks like from afar), so the same seed and the same actions give the same observations.
"""

from __future__ import annotations

import difflib
import math
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from ._errors import ConfigError


class HouseEnvConfig(BaseModel):
    """Sensing, control and rendering options of ``HouseEnv`` (all have defaults)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    scan_rays: int = Field(36, ge=4, le=720)
    """Rays of the 2-D range scan, counter-clockwise from straight ahead."""
    scan_range: float = Field(8.0, gt=0)
    """Range of the scan (metres); a ray that hits nothing reads this."""
    sensing_range: float = Field(6.0, gt=0)
    """Detection range (metres, horizontal) of doors, furniture and containers."""
    item_range: float | None = Field(None, gt=0)
    """Detection range of objects and tools (small things), when shorter than
    ``sensing_range``; None: the same."""
    field_of_view: float = Field(360.0, gt=0, le=360)
    """Detection field of view (degrees, centred straight ahead); 360 is all-round."""
    position_noise: tuple[float, float] = (0.0, 0.0)
    """Standard deviation of a detection's position error, ``a + b * distance`` (metres),
    drawn independently at every step."""
    miss_rate: tuple[float, float] = (0.0, 0.0)
    """Chance that a visible item goes undetected at a step, ``a + b * distance`` (capped at
    0.9); a third of it for doors, furniture and containers."""
    category_confusion: float = Field(0.0, ge=0, le=1)
    """Share of the objects and tools that read as a look-alike category (``CONFUSABLE``)
    whenever seen from farther than their own distance (``confusion_beyond``); half of it
    for furniture and containers; doors never. A detector's mistakes come from how a thing
    looks, so they repeat: looking again from afar does not help, a closer look does."""
    colour_confusion: float = Field(0.0, ge=0, le=1)
    """Share of the things that read as a look-alike colour (``CONFUSABLE_COLOURS``) from
    afar, as ``category_confusion``."""
    confusion_beyond: tuple[float, float] = (1.0, 3.0)
    """The distance (metres) beyond which a confusable object or tool reads as its
    look-alike, drawn once per thing and episode, uniformly in this range; for furniture and
    containers scaled by ``sensing_range / item_range``. Closer, it reads right."""
    odometry_noise: tuple[float, float] = (0.0, 0.0)
    """Odometry drift: standard deviation of the translation error per metre driven (along
    and across), and of the heading error per radian turned (plus a fifth of it per metre
    driven). The error accumulates; ``odometry`` is the drifting estimate."""
    room_sign: Literal["always", "on_entry"] = "always"
    """``always``: ``room``/``room_type`` give the current room at every step. ``on_entry``:
    only at reset and at the step the robot enters another room (a sign by the doorway);
    -1 otherwise."""
    reveal_exceptions: bool = True
    """True: a locked door shows ``locked`` (its lamp turns red) and an unavailable container
    shows ``unavailable`` (grey, shut). False: both look as before and fail when used."""
    reach: float = Field(1.3, gt=0)
    """Reach to an item's centre (pick, use on an item)."""
    furniture_reach: float = Field(0.8, gt=0)
    """Reach to a furniture or container footprint (open, close, place, use)."""
    door_reach: float = Field(1.5, gt=0)
    """Reach to a doorway's centre (open, close)."""
    max_detections: int = Field(32, ge=1, le=256)
    """Rows of the fixed-size detection arrays (the nearest are kept)."""
    max_forward: float = Field(0.5, gt=0)
    """Metres moved by ``move`` with forward = 1."""
    max_turn: float = Field(math.pi / 4, gt=0)
    """Radians turned by ``move`` with turn = 1 (counter-clockwise)."""
    turn_steps: int = Field(25, ge=1)
    forward_steps: int = Field(40, ge=1)
    settle_steps: int = Field(20, ge=0)
    door_steps: int = Field(60, ge=1)
    action_steps: int = Field(10, ge=1)
    """Physics steps of noop, pick, place, use and container open/close."""
    render_rgbd: bool = False
    """Add ``rgb``, ``depth`` and ``segmentation`` images from the robot's eye camera."""
    image_size: tuple[int, int] = (128, 96)
    """(width, height) of the images."""
    detections: bool = True
    """False: no detector (the ``vision`` split): the ``det_*`` arrays are left out of the
    observation and ``info.detections`` is empty."""
    segmentation: bool = True
    """False: the ``segmentation`` image is left out of the observation; it is still
    rendered with every frame and kept host-side, to resolve actions by pixel."""
    held: Literal["id", "flag"] = "id"
    """What ``held`` reports. ``id``: the instance id of the held item (-1: hand empty).
    ``flag``: 1 when the hand holds something, else 0 (the ``vision`` split: an id would
    name what the camera shows no id of)."""
    actions_by: Literal["id", "pixel"] = "id"
    """What names the thing an action acts on. ``id``: ``target``/``tool`` instance ids.
    ``pixel``: ``target_px``/``tool_px``, a pixel ``[u, v]`` (column, row) of the last
    frame observed; the instance under it is acted on under the same rules (in view, in
    reach); a pixel on nothing fails with ``nothing_there``, an id with
    ``ids_not_accepted``. Needs ``render_rgbd``."""
    failure_penalty: float = 0.01
    """Reward subtracted for a failed action when a task is set."""

    @model_validator(mode="after")
    def _pixels_need_frames(self) -> HouseEnvConfig:
        if self.actions_by == "pixel" and not self.render_rgbd:
            raise ValueError("actions_by='pixel' needs render_rgbd=True: a pixel names a "
                             "point of the camera frame")
        return self

    @property
    def exact(self) -> bool:
        """True when detections and odometry carry no noise at all."""
        return (
            self.position_noise == (0.0, 0.0)
            and self.miss_rate == (0.0, 0.0)
            and self.category_confusion == 0.0
            and self.colour_confusion == 0.0
            and self.odometry_noise == (0.0, 0.0)
        )

    @classmethod
    def from_overrides(
        cls, base: HouseEnvConfig | None, overrides: dict[str, Any]
    ) -> HouseEnvConfig:
        """A config from a base and keyword overrides; unknown names raise with a suggestion."""
        for key in overrides:
            if key not in cls.model_fields:
                near = difflib.get_close_matches(key, list(cls.model_fields), n=1)
                hint = f"; did you mean {near[0]!r}?" if near else ""
                raise ConfigError(f"unknown HouseEnv option {key!r}{hint}")
        data = (base or cls()).model_dump()
        data.update(overrides)
        return cls.model_validate(data)
