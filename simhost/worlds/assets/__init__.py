"""The asset library: textures and meshes for houses and benches a vision model can see.

Data, not code: ``textures/*.png``, ``meshes/*.{obj,stl}`` and their ``LICENSES/``, each file
reproduced from pinned wheels or made in code by ``python -m simhost.worlds.assets.reproduce`` (see
``README.md``: where each file comes from, its license, and which category it dresses).
Importing this package imports numpy only.
"""

from __future__ import annotations

from pathlib import Path

from ._looks import FLOORS, TRACK1_LOOKS, TRACK2_LOOKS, WALLS, Fit, Look, Part, fit, mesh_bounds
from ._sources import SOURCES, Source

__all__ = [
    "ASSET_DIR",
    "FLOORS",
    "WALLS",
    "SOURCES",
    "TRACK1_LOOKS",
    "TRACK2_LOOKS",
    "Fit",
    "Look",
    "Part",
    "Source",
    "fit",
    "mesh_bounds",
]

ASSET_DIR = Path(__file__).resolve().parent
"""The folder of ``textures/``, ``meshes/`` and ``LICENSES/``."""
