"""The sanity arena (``eagc/Sanity-v0``): a point robot must find and reach a target.

Importing this package imports no MuJoCo: the arena's names load ``_arena`` on first use.
``import simhost`` registers ``eagc/Sanity-v0`` with gymnasium (``_register.py``).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from simhost.worlds.sanity._register import ENV_ID, register_envs

if TYPE_CHECKING:
    from simhost.worlds.sanity._arena import (
        HALF,
        MAX_DEPTH,
        REACH_RADIUS,
        SENSE_RADIUS,
        SanityArenaEnv,
        sample_point,
    )

_LAZY = ("HALF", "MAX_DEPTH", "REACH_RADIUS", "SENSE_RADIUS", "SanityArenaEnv", "sample_point")

__all__ = ["ENV_ID", "HALF", "MAX_DEPTH", "REACH_RADIUS", "SENSE_RADIUS", "SanityArenaEnv",
           "register_envs", "sample_point"]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module("simhost.worlds.sanity._arena"), name)
    raise AttributeError(f"module 'simhost.worlds.sanity' has no attribute {name!r}")
