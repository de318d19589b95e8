"""The Track 2 split parameter ``image_size`` (issue 24 §2)."""

from __future__ import annotations

import pytest

from plugins._errors import PluginError
from plugins.track2._scenario import make_track2_scenario, split_params
from simhost.worlds.track2 import OFFICIAL_IMAGE_SIZE


def test_split_image_size_parameter() -> None:
    scen = make_track2_scenario(60540, "standard", {"image_size": [224, 224]}, index=0)
    assert scen.bench.observation.image_size == (224, 224)
    default = make_track2_scenario(60540, "standard", {}, index=0)
    assert default.bench.observation.image_size == OFFICIAL_IMAGE_SIZE
    with pytest.raises(PluginError, match="image_size must be \\[height, width\\]"):
        split_params("standard", {"image_size": [224]})
