"""Options of the Track 1 environment, grouped in one frozen model."""

from __future__ import annotations

import difflib
import math
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from ._errors import ConfigError


class HouseEnvConfig(BaseModel):
    """Sensing, control and rendering options of ``HouseEnv`` (all have defaults)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    scan_rays: int = Field(36, ge=4, le=720)
    """Rays of the 2-D range scan, counter-clockwise from straight ahead."""
    scan_range: float = Field(8.0, gt=0)
    """Range of the scan (metres); a ray that hits nothing reads this."""
    sensing_range: float = Field(6.0, gt=0)
    """Detection range (metres, horizontal)."""
    max_detections: int = Field(32, ge=1, le=256)
    """Rows of the fixed-size detection arrays (the nearest are kept)."""
    reach: float = Field(1.3, gt=0)
    """Reach to an item's centre (pick, use on an item)."""
    furniture_reach: float = Field(0.8, gt=0)
    """Reach to a furniture or container footprint (open, close, place, use)."""
    door_reach: float = Field(1.5, gt=0)
    """Reach to a doorway's centre (open, close)."""
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
    failure_penalty: float = 0.01
    """Reward subtracted for a failed action when a task is set."""

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
