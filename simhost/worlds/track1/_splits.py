"""The splits of Track 1: which houses and what the robot perceives, as one typed config.

A ``HouseSplit`` pairs the generator's parameters (``HouseParams``: rooms, clutter,
look-alikes) with the environment's sensing options (``HouseEnvConfig``). The Gymnasium ids
and the Track 1 plugin take their configuration from here, so that an agent trained offline
sees what the evaluation shows it.

- ``dev``: the public level for getting started: 3-5 rooms, exact all-round perception
  (6 m), the true room at every step, exceptions that show themselves.
- ``standard``: 3-5 rooms with look-alike objects and more of them closed away in
  containers; a robot's perception: a 120-degree field of view, 5 m range for doors and
  furniture and 3 m for objects and tools (small things), position noise growing with
  distance, missed detections, look-alikes from afar (a fifth of the objects and tools read
  as a look-alike category, some as a look-alike colour, whenever seen from beyond 1-3 m),
  odometry drift, the room read from a sign on entry, exceptions that show only through
  their effects; egocentric RGB-D with instance segmentation at 96x72.
- ``challenge``: the same robot in 6-8 room houses with more clutter and look-alikes.
- ``vision``: the standard split's houses and robot without a detector: RGB-D, odometry,
  the range scan and the room sign; no ``det_*`` arrays and no ``segmentation`` image (the
  host keeps its segmentation to itself). An action names what it acts on by a pixel of
  the last frame (``target_px``, ``tool_px``), never by an id.
"""

from __future__ import annotations

import difflib
from typing import Any

from pydantic import BaseModel, ConfigDict

from ._config import HouseEnvConfig
from ._errors import ConfigError
from ._layout import HouseParams


class HouseSplit(BaseModel):
    """One split's houses and sensing (``model_dump(mode="json")`` round-trips)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str
    params: HouseParams
    config: HouseEnvConfig

    def with_overrides(
        self, params: dict[str, Any] | None = None, config: dict[str, Any] | None = None
    ) -> HouseSplit:
        """The split with some generator parameters and sensing options replaced; unknown
        names raise ``ConfigError`` with a suggestion."""
        new_params = self.params
        if params:
            for key in params:
                if key not in HouseParams.model_fields:
                    near = difflib.get_close_matches(key, list(HouseParams.model_fields), n=1)
                    hint = f"; did you mean {near[0]!r}?" if near else ""
                    raise ConfigError(f"unknown house parameter {key!r}{hint}")
            new_params = HouseParams.model_validate({**self.params.model_dump(), **params})
        new_config = HouseEnvConfig.from_overrides(self.config, dict(config or {}))
        return self.model_copy(update={"params": new_params, "config": new_config})


ROBOT_SENSING = HouseEnvConfig(
    field_of_view=120.0,
    sensing_range=5.0,
    item_range=3.0,
    position_noise=(0.02, 0.03),
    miss_rate=(0.05, 0.04),
    category_confusion=0.2,
    colour_confusion=0.15,
    confusion_beyond=(1.0, 3.0),
    odometry_noise=(0.02, 0.01),
    room_sign="on_entry",
    reveal_exceptions=False,
    render_rgbd=True,
    image_size=(256, 192),
)
"""What the robot perceives on the official splits. 256x192 keeps the 4:3 view (75 degrees
high, 91 wide) of the earlier 96x72 images at the pixel count of a 224x224 vision model's
input (49,152 vs 50,176 pixels): a team resizes or crops without losing the field of view."""

VISION_SENSING = ROBOT_SENSING.model_copy(
    update={"detections": False, "segmentation": False, "actions_by": "pixel",
            "held": "flag"})
"""The official robot with no detector: what it sees is pixels (``vision``)."""

SPLITS: dict[str, HouseSplit] = {
    "dev": HouseSplit(name="dev", params=HouseParams.dev(), config=HouseEnvConfig()),
    "standard": HouseSplit(name="standard", params=HouseParams.standard(), config=ROBOT_SENSING),
    "challenge": HouseSplit(
        name="challenge", params=HouseParams.challenge(), config=ROBOT_SENSING
    ),
    "vision": HouseSplit(name="vision", params=HouseParams.standard(), config=VISION_SENSING),
}


def house_split(name: str) -> HouseSplit:
    """The preset of a split (``dev``, ``standard``, ``challenge`` or ``vision``)."""
    try:
        return SPLITS[name]
    except KeyError:
        near = difflib.get_close_matches(name, list(SPLITS), n=1)
        hint = f"; did you mean {near[0]!r}?" if near else ""
        raise ConfigError(f"unknown split {name!r}{hint}; one of {sorted(SPLITS)}") from None
